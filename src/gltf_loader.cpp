/* gltf_loader.cpp: glTF 2.0 (.gltf/.glb) into a pm_scene through tinygltf, with every check tinygltf 2.7 leaves out.
 *
 * The only translation unit that sees tinygltf. A load runs in three stages, each refusing bad
 * input before the next one can trip over it:
 *   1. preflight, on the raw bytes and the JSON parsed once (nlohmann): GLB container, JSON syntax
 *      and nesting depth, asset.version, required extensions, every index and size field as
 *      written (tinygltf turns -1 into "absent" and truncates 2^32 to 0), buffer and image URIs
 *      (refused before anything is opened) and bufferView byte ranges (tinygltf decodes images
 *      straight out of bufferViews without checking them);
 *   2. tinygltf's own per-object parsers build its Model from that same document (the text is
 *      never parsed again) and read buffers and images, through file-system callbacks that refuse
 *      any path outside the model's folder and an image hook that decodes only the images used by
 *      the textures pmview renders, after checking their size;
 *   3. conversion: accessor layouts are validated with overflow-checked 64-bit arithmetic before
 *      anything sized by a count is allocated, the default scene is walked iteratively with a
 *      visited set, each mesh is decoded once (index values, finite positions) and copied into
 *      world space, or, placed by several nodes, stored once in mesh space with a placement per
 *      node (scene.h, Instancing; place_instanced_meshes).
 * Any problem throws LoadError; pm_load_gltf turns it into the one line "FILE: what (where)".
 */
// tinygltf is compiled inside an unnamed namespace, so its functions are local to this file and the
// compiler drops those the loader never calls (its glTF writer and the JSON output it needs): a fifth
// of this object's machine code, not compiled at all. The headers tinygltf includes on this platform
// are included first, outside the namespace, so the standard library, nlohmann's JSON (hidden, as
// tinygltf includes it) and stb_image keep their usual linkage; their include guards keep tinygltf
// from including them again inside.
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>
#pragma GCC visibility push(hidden)
#include <nlohmann/json.hpp>
#pragma GCC visibility pop
#include <stb_image.h>
#define TINYGLTF_IMPLEMENTATION
#define TINYGLTF_NO_STB_IMAGE_WRITE
namespace {
#include <tiny_gltf.h>
}

#include <sys/stat.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cfloat>
#include <chrono>
#include <climits>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

extern "C" {
#include "compressed.h"
#include "defaults.h"
#include "loader.h"
#include "memory.h"
}
#include "parallel.h"

namespace {

using json = nlohmann::json;
using tinygltf::Model;

// A scene larger than this is refused before its arrays are allocated: instancing can multiply a
// small file into any number of triangles.
const uint64_t kMaxSceneVertices = 1ull << 27;
const uint64_t kMaxSceneTriangles = 1ull << 27;
// An accessor without a bufferView is zero-filled; its count is not bounded by any data.
const uint64_t kMaxZeroFilledElements = 1ull << 24;
// A base colour image is decoded only when it has at most this many pixels (1 GiB as RGBA8).
const uint64_t kMaxImagePixels = 1ull << 28;
// tinygltf and nlohmann recurse over nested JSON (extras); no glTF needs this depth.
const int kMaxJsonDepth = 128;

const char *const kSupportedExtensions[] = {"KHR_lights_punctual", "KHR_materials_emissive_strength",
                                            "KHR_materials_transmission", "KHR_materials_ior",
                                            "KHR_texture_transform", "KHR_mesh_quantization", "KHR_materials_volume",
                                            "KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_specular",
                                            "KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_materials_unlit",
                                            "EXT_mesh_gpu_instancing", "KHR_materials_variants"};

// ---------------- errors and messages

struct LoadError {
    std::string message;  // "what (where)", without the file name
};

[[noreturn]] void fail(const std::string &message) { throw LoadError{message}; }

std::string str(uint64_t n) { return std::to_string(n); }

// A value from the file as it appears in a warning.
std::string num(double v) {
    char text[32];
    snprintf(text, sizeof text, "%.6g", v);
    return text;
}

// Bytes of the character at s[i] when it is printable ASCII or well-formed UTF-8 that is not a
// control character (C1 controls such as U+009B act on terminals too), else 0.
size_t printable_character(const std::string &s, size_t i) {
    unsigned char c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) return 1;
    size_t n = (c >= 0xc2 && c <= 0xdf) ? 2 : (c >= 0xe0 && c <= 0xef) ? 3 : (c >= 0xf0 && c <= 0xf4) ? 4 : 0;
    if (n == 0 || i + n > s.size()) return 0;
    uint32_t code = c & (0xffu >> (n + 1));
    for (size_t k = 1; k < n; k++) {
        unsigned char d = static_cast<unsigned char>(s[i + k]);
        if ((d & 0xc0) != 0x80) return 0;
        code = code << 6 | (d & 0x3fu);
    }
    static const uint32_t shortest[5] = {0, 0, 0xa0, 0x800, 0x10000};  // 0xa0: above the C1 controls
    bool ok = code >= shortest[n] && code <= 0x10ffff && !(code >= 0xd800 && code <= 0xdfff);
    return ok ? n : 0;
}

// Text that came from the file (or a library quoting it), safe to print: anything that is not
// printable ASCII or well-formed UTF-8 becomes '?', and it is cut after `limit` bytes.
std::string printable(const std::string &s, size_t limit = 64) {
    std::string out;
    size_t i = 0;
    while (i < s.size() && i < limit) {
        size_t n = printable_character(s, i);
        out += n ? s.substr(i, n) : "?";
        i += n ? n : 1;
    }
    if (i < s.size()) out += "...";
    return out;
}

// A multi-line library message (tinygltf, nlohmann) as one line.
std::string one_line(const std::string &s, size_t limit = 300) {
    std::string joined, line;
    auto flush = [&]() {
        size_t first = line.find_first_not_of(' '), last = line.find_last_not_of(' ');
        if (first != std::string::npos) {
            if (!joined.empty()) joined += "; ";
            joined += line.substr(first, last - first + 1);
        }
        line.clear();
    };
    for (char c : s) {
        if (c == '\n' || c == '\r') flush();
        else line += c;
    }
    flush();
    return printable(joined, limit);
}

std::string describe(const json &v) {
    if (v.is_object()) return "an object";
    if (v.is_array()) return "an array";
    return printable(v.dump(-1, ' ', false, json::error_handler_t::replace), 40);
}

// ---------------- paths

// A path reduced lexically: "." and empty segments dropped, "a/.." folded; ".." survives only at the front.
struct LexicalPath {
    bool absolute = false;
    std::vector<std::string> segments;
};

LexicalPath lexical_normal(const std::string &path) {
    LexicalPath p;
    p.absolute = !path.empty() && path[0] == '/';
    size_t start = 0;
    while (start <= path.size()) {
        size_t end = path.find('/', start);
        if (end == std::string::npos) end = path.size();
        std::string seg = path.substr(start, end - start);
        if (seg == "..") {
            if (!p.segments.empty() && p.segments.back() != "..") p.segments.pop_back();
            else if (!p.absolute) p.segments.push_back(seg);
        } else if (!seg.empty() && seg != ".") {
            p.segments.push_back(seg);
        }
        start = end + 1;
    }
    return p;
}

// True when path names something strictly inside folder (lexically; symbolic links are not followed).
bool is_inside(const LexicalPath &folder, const std::string &path) {
    LexicalPath p = lexical_normal(path);
    if (p.absolute != folder.absolute || p.segments.size() <= folder.segments.size()) return false;
    if (!std::equal(folder.segments.begin(), folder.segments.end(), p.segments.begin())) return false;
    return std::find(p.segments.begin() + static_cast<long>(folder.segments.size()), p.segments.end(), "..") ==
           p.segments.end();
}

// The way tinygltf joins a uri to its base folder.
std::string join_path(const std::string &folder, const std::string &relative) {
    if (folder.empty()) return relative;
    return folder.back() == '/' ? folder + relative : folder + "/" + relative;
}

// Bytes admitted against --max-memory, given back when the holder goes (a failed load included).
struct Admitted {
    uint64_t bytes = 0;
    Admitted() = default;
    Admitted(const Admitted &) = delete;
    Admitted &operator=(const Admitted &) = delete;
    ~Admitted() { pm_memory_release(bytes); }
};

// An image load_wanted_image has checked and admitted, its decode put off so that the model's
// images decode side by side (decode_pending_images): one after another on one core, decoding PNGs
// and JPEGs is most of a textured model's load.
struct PendingImage {
    int index, req_width, req_height;
    std::vector<unsigned char> encoded;  // the file's bytes, copied: tinygltf frees its own after the hook
    uint64_t held;                       // the decoded texels' bytes; twice this is admitted while decoding
    bool attempted, decoded;
    std::string error;
};

// What the file-system hooks and the image hook need; their refusals are kept to report them in our words.
struct TinygltfHooks {
    LexicalPath folder;
    bool no_files = false;  // loading from memory: there is no folder to read external files from
    std::vector<char> image_wanted;  // per image: used by a texture pmview renders (base colour, emissive, data)
    Admitted decoded;                // the decoded images, held by the model as long as the loader lives
    std::string error;
    std::vector<std::string> warnings;
    std::vector<tinygltf::Image> *images = nullptr;  // the model's, where the pending images are decoded into
    std::vector<PendingImage> pending;
};

void decode_one_image(void *ctx, size_t task, int) noexcept {
    TinygltfHooks *hooks = static_cast<TinygltfHooks *>(ctx);
    PendingImage &job = hooks->pending[task];
    job.attempted = true;
    std::string decode_warning;
    try {
        job.decoded = tinygltf::LoadImageData(&(*hooks->images)[job.index], job.index, &job.error, &decode_warning,
                                              job.req_width, job.req_height, job.encoded.data(),
                                              static_cast<int>(job.encoded.size()), nullptr);
    } catch (const std::bad_alloc &) {  // a worker's exception must not leave it (noexcept: it would end the process)
        job.decoded = false;
        job.error = "out of memory";
    } catch (const std::exception &e) {
        job.decoded = false;
        job.error = e.what();
    } catch (...) {
        job.decoded = false;
        job.error = "decoder failure";
    }
    std::vector<unsigned char>().swap(job.encoded);  // the file's copy, no longer needed
}

// Decodes the pending images on every core (stb_image keeps no shared state), then, in their
// order, gives back what each no longer needs (the second copy of the texels a decode holds for a
// moment, or both where it failed) and warns of those that failed.
void decode_pending_images(TinygltfHooks *hooks) {
    if (hooks->pending.empty()) return;
    pm_parallel_for(pm_thread_count(pm_cpu_count()), hooks->pending.size(), decode_one_image, hooks);
    // a parallel-for on a thread whose cancel flag is up hands out no more tasks: those are decoded here
    for (size_t i = 0; i < hooks->pending.size(); i++)
        if (!hooks->pending[i].attempted) decode_one_image(hooks, i, 0);
    for (PendingImage &job : hooks->pending) {
        uint64_t unused = job.decoded ? job.held : 2 * job.held;
        hooks->decoded.bytes -= unused;
        pm_memory_release(unused);
        if (!job.decoded)
            hooks->warnings.push_back("image " + str(job.index) + " could not be decoded (" + one_line(job.error, 120) +
                                      "); its textures are ignored");
    }
    hooks->pending.clear();
}

bool guarded_file_exists(const std::string &path, void *user) {
    TinygltfHooks *hooks = static_cast<TinygltfHooks *>(user);
    return !hooks->no_files && is_inside(hooks->folder, path) && tinygltf::FileExists(path, nullptr);
}

std::string unexpanded_path(const std::string &path, void *) { return path; }

bool guarded_read_file(std::vector<unsigned char> *out, std::string *err, const std::string &path, void *user) {
    TinygltfHooks *hooks = static_cast<TinygltfHooks *>(user);
    if (hooks->no_files) {
        hooks->error = "cannot read " + printable(path) + ": external files are unavailable when loading from memory";
        if (err) *err = hooks->error;
        return false;
    }
    if (!is_inside(hooks->folder, path)) {
        hooks->error = "refused to read " + printable(path) + ": outside the model's folder";
        if (err) *err = hooks->error;
        return false;
    }
    return tinygltf::ReadWholeFile(out, err, path, nullptr);
}

bool refuse_write(std::string *err, const std::string &, const std::vector<unsigned char> &, void *) {
    if (err) *err = "writing is disabled";
    return false;
}

// Decodes (with tinygltf's own stb_image loader) only the images a rendered texture uses,
// after checking their dimensions and admitting their decoded size from the header alone (a
// 16384-square image must be refused before its gigabytes are spent); an image that cannot be
// decoded becomes a warning, not a failure.
bool load_wanted_image(tinygltf::Image *image, const int index, std::string *, std::string *, int req_width,
                       int req_height, const unsigned char *bytes, int size, void *user) {
    TinygltfHooks *hooks = static_cast<TinygltfHooks *>(user);
    if (index < 0 || static_cast<size_t>(index) >= hooks->image_wanted.size() || !hooks->image_wanted[index])
        return true;
    int width = 0, height = 0, channels = 0;
    if (!stbi_info_from_memory(bytes, size, &width, &height, &channels)) {
        // stb_image turns down a PNG header past its own limit (2^24 a side) as undecodable: the
        // header's size, read here, says why
        static const unsigned char png[12] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n', 0, 0, 0, 13};
        if (size >= 24 && memcmp(bytes, png, sizeof png) == 0 && memcmp(bytes + 12, "IHDR", 4) == 0) {
            auto be32 = [&](int at) {
                return static_cast<uint64_t>(bytes[at]) << 24 | static_cast<uint64_t>(bytes[at + 1]) << 16 |
                       static_cast<uint64_t>(bytes[at + 2]) << 8 | bytes[at + 3];
            };
            uint64_t w = be32(16), h = be32(20);
            if (w * h > kMaxImagePixels) {
                hooks->error = "image is " + str(w) + "x" + str(h) + " pixels, more than " + str(kMaxImagePixels) +
                               " (image " + str(index) + ")";
                return false;
            }
        }
        hooks->warnings.push_back("image " + str(index) + " is not a decodable PNG/JPEG/BMP/GIF; its textures are ignored");
        return true;
    }
    // stb_image's info reports a top-down BMP's height as written, negative; its decoder flips the rows
    if (height < 0 && height != INT_MIN) height = -height;
    if (width <= 0 || height <= 0) {
        hooks->warnings.push_back("image " + str(index) + " has no valid size; its textures are ignored");
        return true;
    }
    if (static_cast<uint64_t>(width) * static_cast<uint64_t>(height) > kMaxImagePixels) {
        hooks->error = "image is " + str(width) + "x" + str(height) + " pixels, more than " + str(kMaxImagePixels) +
                       " (image " + str(index) + ")";
        return false;
    }
    // tinygltf asks stb for 4 channels (8 or 16 bits) and copies stb's buffer before freeing it:
    // the decode needs twice what the model then holds. (The file's copy that waits for it is, as
    // the buffers' bytes are, the model's input, not admitted.)
    uint64_t held = static_cast<uint64_t>(width) * static_cast<uint64_t>(height) * 4 *
                    (stbi_is_16_bit_from_memory(bytes, size) ? 2 : 1);
    const uint64_t mark = pm_memory_failure_mark();  // this refusal's line, never an older failure's
    bool admitted = pm_memory_admit(2 * held, "decoded image");
    if (!admitted && !hooks->pending.empty()) {
        // the images put off hold their second copies until decoded: with those given back, as
        // one decode after another would have, this one may fit; asked again, the answer (and a
        // refusal's line) is the second ask's
        pm_memory_forgive_last();
        decode_pending_images(hooks);
        admitted = pm_memory_admit(2 * held, "decoded image");
    }
    if (!admitted) {
        hooks->error = "out of memory (" + std::string(pm_memory_failure_since_or(mark, "decoded image")) + "): image " + str(index);
        return false;
    }
    hooks->decoded.bytes += 2 * held;  // given back with the hooks should the decode throw
    hooks->pending.push_back(PendingImage{index, req_width, req_height, std::vector<unsigned char>(bytes, bytes + size), held,
                                          false, false, std::string()});
    return true;
}

// ---------------- raw JSON access

const json *find_member(const json &object, const char *key) {
    if (!object.is_object()) return nullptr;
    auto it = object.find(key);
    return it == object.end() ? nullptr : &*it;
}

const json &optional_array(const json &parent, const char *key, const std::string &where) {
    static const json empty = json::array();
    const json *v = find_member(parent, key);
    if (!v) return empty;
    if (!v->is_array()) fail(std::string(key) + " must be an array (" + where + ")");
    return *v;
}

// Calls f(object, "singular i", i) for each element of a top-level array, each required to be an object.
template <class F>
void for_each_object(const json &parent, const char *key, const char *singular, F f) {
    const json &items = optional_array(parent, key, "top level");
    for (size_t i = 0; i < items.size(); i++) {
        std::string where = std::string(singular) + " " + str(i);
        if (!items[i].is_object()) fail(where + " is not a JSON object");
        f(items[i], where, i);
    }
}

// An index as written: an integer in [0, count), else a LoadError naming the target and where it was.
int index_value(const json &v, size_t count, const char *target, const std::string &where) {
    if (v.is_number_unsigned()) {
        uint64_t i = v.get<uint64_t>();
        if (i >= count) fail(std::string(target) + " " + str(i) + " does not exist (" + where + ")");
        return static_cast<int>(i);
    }
    if (v.is_number_integer())
        fail(std::string("invalid (negative) ") + target + " index " + std::to_string(v.get<int64_t>()) + " (" +
             where + ")");
    fail(std::string(target) + " index must be a non-negative integer, got " + describe(v) + " (" + where + ")");
}

int optional_index(const json &object, const char *key, size_t count, const char *target, const std::string &where) {
    const json *v = find_member(object, key);
    return v ? index_value(*v, count, target, where) : -1;
}

int required_index(const json &object, const char *key, size_t count, const char *target, const std::string &where) {
    const json *v = find_member(object, key);
    if (!v) fail(std::string("missing ") + key + " (" + where + ")");
    return index_value(*v, count, target, where);
}

uint64_t unsigned_member(const json &object, const char *key, bool required, uint64_t fallback, uint64_t max,
                         const std::string &where) {
    const json *v = find_member(object, key);
    if (!v) {
        if (required) fail(std::string("missing ") + key + " (" + where + ")");
        return fallback;
    }
    if (!v->is_number_unsigned() || v->get<uint64_t>() > max)
        fail(std::string(key) + " must be an integer in [0, " + str(max) + "], got " + describe(*v) + " (" + where +
             ")");
    return v->get<uint64_t>();
}

// Typed members as glTF's schema defines them. tinygltf quietly keeps the default for a member of
// the wrong type or length (a 3-number baseColorFactor, a string roughnessFactor), which would
// render a different material than the file's author wrote: these refuse such a member instead.
const json *typed_object(const json &object, const char *key, const std::string &where) {
    const json *v = find_member(object, key);
    if (v && !v->is_object()) fail(std::string(key) + " must be an object, got " + describe(*v) + " (" + where + ")");
    return v;
}

void typed_number(const json &object, const char *key, bool required, const std::string &where) {
    const json *v = find_member(object, key);
    if (!v) {
        if (required) fail(std::string("missing ") + key + " (" + where + ")");
        return;
    }
    if (!v->is_number() || !std::isfinite(v->get<double>()))
        fail(std::string(key) + " must be a finite number, got " + describe(*v) + " (" + where + ")");
}

// An array of exactly `size` finite numbers (any length when size is 0).
void typed_numbers(const json &object, const char *key, size_t size, const std::string &where) {
    const json *v = find_member(object, key);
    if (!v) return;
    std::string wanted = size ? str(size) + " numbers" : std::string("an array of numbers");
    if (!v->is_array()) fail(std::string(key) + " must be " + wanted + ", got " + describe(*v) + " (" + where + ")");
    if (size && v->size() != size)
        fail(std::string(key) + " must be " + wanted + ", got " + str(v->size()) + " (" + where + ")");
    for (size_t i = 0; i < v->size(); i++)
        if (!(*v)[i].is_number() || !std::isfinite((*v)[i].get<double>()))
            fail(std::string(key) + " must be " + wanted + ", got " + describe((*v)[i]) + " at [" + str(i) + "] (" +
                 where + ")");
}

void typed_bool(const json &object, const char *key, const std::string &where) {
    const json *v = find_member(object, key);
    if (v && !v->is_boolean()) fail(std::string(key) + " must be true or false, got " + describe(*v) + " (" + where + ")");
}

// A string member; when `allowed` is given, one of those values (glTF's enumerations).
void typed_string(const json &object, const char *key, bool required, std::initializer_list<const char *> allowed,
                  const std::string &where) {
    const json *v = find_member(object, key);
    if (!v) {
        if (required) fail(std::string("missing ") + key + " (" + where + ")");
        return;
    }
    if (!v->is_string()) fail(std::string(key) + " must be a string, got " + describe(*v) + " (" + where + ")");
    if (allowed.size() == 0) return;
    std::string names;
    for (const char *a : allowed) {
        if (v->get_ref<const std::string &>() == a) return;
        names += (names.empty() ? "" : ", ") + std::string(a);
    }
    fail(std::string(key) + " must be one of " + names + ", got " + describe(*v) + " (" + where + ")");
}

// Deepest [ / { nesting of a JSON text, strings skipped; stops counting once past the limit.
int json_depth(const char *text, size_t size) {
    int depth = 0, deepest = 0;
    bool in_string = false;
    for (size_t i = 0; i < size && deepest <= kMaxJsonDepth; i++) {
        char c = text[i];
        if (in_string) {
            if (c == '\\') i++;
            else if (c == '"') in_string = false;
        } else if (c == '"') {
            in_string = true;
        } else if (c == '[' || c == '{') {
            deepest = std::max(deepest, ++depth);
        } else if (c == ']' || c == '}') {
            depth--;
        }
    }
    return deepest;
}

// Decoded size of a data: URI in one of the forms tinygltf decodes, or -1 when it is malformed.
int64_t data_uri_size(const std::string &uri) {
    static const char *const prefixes[] = {
        "data:application/octet-stream;base64,", "data:application/gltf-buffer;base64,", "data:image/png;base64,",
        "data:image/jpeg;base64,", "data:image/bmp;base64,", "data:image/gif;base64,", "data:text/plain;base64,"};
    for (const char *prefix : prefixes) {
        size_t start = strlen(prefix);
        if (uri.compare(0, start, prefix) != 0) continue;
        if (uri.size() - start > static_cast<size_t>(INT_MAX)) return -1;  // tinygltf decodes with int lengths
        uint64_t symbols = 0, padding = 0;
        for (size_t i = start; i < uri.size(); i++) {
            char c = uri[i];
            bool base64 = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '+' ||
                          c == '/';
            if (c == '=') padding++;
            else if (base64 && padding == 0) symbols++;
            else return -1;
        }
        if (padding > 2 || symbols % 4 == 1 || (padding && (symbols + padding) % 4 != 0)) return -1;
        int64_t bytes = static_cast<int64_t>(symbols / 4 * 3 + (symbols % 4 ? symbols % 4 - 1 : 0));
        return bytes > 0 ? bytes : -1;
    }
    return -1;
}

bool is_hex(char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f') || (c >= 'A' && c <= 'F'); }
int hex_value(char c) { return c <= '9' ? c - '0' : (c | 0x20) - 'a' + 10; }

bool starts_with_data_scheme(const std::string &uri) {
    static const char scheme[] = "data:";
    if (uri.size() < 5) return false;
    for (size_t i = 0; i < 5; i++)
        if ((uri[i] | 0x20) != scheme[i] && uri[i] != scheme[i]) return false;
    return true;
}

// The path a relative URI names, percent-decoded as tinygltf decodes it ('+' included); refuses
// schemes, absolute paths and anything that leaves the model's folder.
std::string safe_relative_path(const std::string &uri, const std::string &folder, const LexicalPath &folder_path,
                               const std::string &where) {
    if (uri.empty()) fail("empty uri (" + where + ")");
    size_t colon = uri.find(':');
    if (colon != std::string::npos && colon > 0 && colon < uri.find_first_of("/?#")) {
        bool scheme = isalpha(static_cast<unsigned char>(uri[0])) != 0;
        for (size_t i = 1; i < colon && scheme; i++)
            scheme = isalnum(static_cast<unsigned char>(uri[i])) || uri[i] == '+' || uri[i] == '-' || uri[i] == '.';
        if (scheme)
            fail("uri scheme " + printable(uri.substr(0, colon)) + ": is not allowed, only relative paths and data: (" +
                 where + ")");
    }
    if (uri[0] == '/' || uri[0] == '\\') fail("absolute path uri " + printable(uri) + " is not allowed (" + where + ")");
    std::string decoded;
    for (size_t i = 0; i < uri.size(); i++) {
        if (uri[i] == '+') {
            decoded += ' ';
        } else if (uri[i] == '%') {
            if (i + 2 >= uri.size() || !is_hex(uri[i + 1]) || !is_hex(uri[i + 2]))
                fail("malformed percent-encoding in uri " + printable(uri) + " (" + where + ")");
            decoded += static_cast<char>(hex_value(uri[i + 1]) * 16 + hex_value(uri[i + 2]));
            i += 2;
        } else {
            decoded += uri[i];
        }
    }
    if (decoded.find('\0') != std::string::npos || decoded[0] == '/')
        fail("uri " + printable(uri) + " is not a plain relative path (" + where + ")");
    if (!is_inside(folder_path, join_path(folder, decoded)))
        fail("uri " + printable(uri) + " escapes the model's folder (" + where + ")");
    return decoded;
}

// ---------------- accessors

size_t component_size(int type) {
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: return 1;
    case TINYGLTF_COMPONENT_TYPE_SHORT: case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: return 2;
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: case TINYGLTF_COMPONENT_TYPE_FLOAT: return 4;
    default: return 0;
    }
}

// One component as a number, normalized integers mapped to [0, 1] or [-1, 1] as the glTF spec says.
double read_component(const unsigned char *p, int type, bool normalized) {
    switch (type) {
    case TINYGLTF_COMPONENT_TYPE_BYTE: {
        int8_t v; memcpy(&v, p, 1);
        return normalized ? std::max(v / 127.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: {
        uint8_t v; memcpy(&v, p, 1);
        return normalized ? v / 255.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_SHORT: {
        int16_t v; memcpy(&v, p, 2);
        return normalized ? std::max(v / 32767.0, -1.0) : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t v; memcpy(&v, p, 2);
        return normalized ? v / 65535.0 : v;
    }
    case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
        uint32_t v; memcpy(&v, p, 4);
        return v;
    }
    default: {
        float v; memcpy(&v, p, 4);
        return v;
    }
    }
}

// Where an accessor's bytes are, after every range has been checked.
struct AccessorLayout {
    const unsigned char *first = nullptr;  // element 0; nullptr: no bufferView, zero-filled
    size_t count = 0, stride = 0, element_size = 0;
    int component_type = 0, components = 0;
    bool normalized = false;
    size_t sparse_count = 0;
    const unsigned char *sparse_indices = nullptr, *sparse_values = nullptr;
    int sparse_index_type = 0;
};

// offset + stride*(count-1) + element bytes, or UINT64_MAX on overflow; 0 for an empty accessor.
uint64_t bytes_needed(uint64_t offset, uint64_t count, uint64_t stride, uint64_t element) {
    if (count == 0) return 0;
    uint64_t span, end, total;
    if (__builtin_mul_overflow(stride, count - 1, &span) || __builtin_add_overflow(offset, span, &end) ||
        __builtin_add_overflow(end, element, &total))
        return UINT64_MAX;
    return total;
}

void check_range(uint64_t needed, uint64_t available, const std::string &what, int view) {
    if (needed > available)
        fail(what + " needs " + (needed == UINT64_MAX ? std::string("more than 2^64") : str(needed)) +
             " bytes but bufferView " + str(view) + " has " + str(available));
}

const unsigned char *view_bytes(const Model &model, int view, size_t offset) {
    const tinygltf::BufferView &bv = model.bufferViews[view];
    return model.buffers[bv.buffer].data.data() + bv.byteOffset + offset;
}

// Validates accessor `index` (every index was range-checked in the preflight) and locates its data.
AccessorLayout accessor_layout(const Model &model, int index) {
    const tinygltf::Accessor &a = model.accessors[index];
    std::string where = "accessor " + str(index);
    AccessorLayout l;
    l.component_type = a.componentType;
    l.components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(a.type));
    size_t size = component_size(a.componentType);
    if (size == 0 || l.components <= 0) fail("unsupported componentType " + str(a.componentType) + " (" + where + ")");
    l.element_size = size * static_cast<size_t>(l.components);
    l.count = a.count;
    l.normalized = a.normalized;
    if (a.bufferView >= 0) {
        const tinygltf::BufferView &bv = model.bufferViews[a.bufferView];
        l.stride = bv.byteStride ? bv.byteStride : l.element_size;
        if (l.stride < l.element_size)
            fail("byteStride " + str(l.stride) + " < element size " + str(l.element_size) + " (" + where +
                 ", bufferView " + str(a.bufferView) + ")");
        check_range(bytes_needed(a.byteOffset, a.count, l.stride, l.element_size), bv.byteLength, where,
                    a.bufferView);
        l.first = view_bytes(model, a.bufferView, a.byteOffset);
    } else if (a.count > kMaxZeroFilledElements) {
        fail("count " + str(a.count) + " without a bufferView (at most " + str(kMaxZeroFilledElements) +
             " zero-filled elements) (" + where + ")");
    }
    if (a.sparse.isSparse) {
        const auto &sp = a.sparse;
        if (sp.count < 1 || static_cast<size_t>(sp.count) > a.count)
            fail("sparse count " + std::to_string(sp.count) + " outside [1, " + str(a.count) + "] (" + where + ")");
        size_t index_size = component_size(sp.indices.componentType);
        if (sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_BYTE ||
            sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_SHORT ||
            sp.indices.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT || index_size == 0)
            fail("sparse indices must be UNSIGNED_BYTE/SHORT/INT, got componentType " +
                 std::to_string(sp.indices.componentType) + " (" + where + ")");
        uint64_t n = static_cast<uint64_t>(sp.count);
        check_range(bytes_needed(static_cast<uint64_t>(sp.indices.byteOffset), n, index_size, index_size),
                    model.bufferViews[sp.indices.bufferView].byteLength, where + " sparse indices",
                    sp.indices.bufferView);
        check_range(bytes_needed(static_cast<uint64_t>(sp.values.byteOffset), n, l.element_size, l.element_size),
                    model.bufferViews[sp.values.bufferView].byteLength, where + " sparse values",
                    sp.values.bufferView);
        l.sparse_count = n;
        l.sparse_index_type = sp.indices.componentType;
        l.sparse_indices = view_bytes(model, sp.indices.bufferView, static_cast<size_t>(sp.indices.byteOffset));
        l.sparse_values = view_bytes(model, sp.values.bufferView, static_cast<size_t>(sp.values.byteOffset));
    }
    return l;
}

// Every element of a validated accessor, components flattened, sparse substitutions applied.
// T is float or uint32_t; callers check the component type first so every value fits.
template <class T>
std::vector<T> read_accessor(const AccessorLayout &l, int index) {
    size_t components = static_cast<size_t>(l.components), csize = component_size(l.component_type);
    std::vector<T> out(l.count * components, T(0));
    if (l.first)
        for (size_t i = 0; i < l.count; i++)
            for (size_t c = 0; c < components; c++)
                out[i * components + c] =
                    static_cast<T>(read_component(l.first + i * l.stride + c * csize, l.component_type, l.normalized));
    size_t index_size = component_size(l.sparse_index_type);
    for (size_t k = 0; k < l.sparse_count; k++) {
        uint64_t target = static_cast<uint64_t>(read_component(l.sparse_indices + k * index_size, l.sparse_index_type, false));
        if (target >= l.count)
            fail("sparse index " + str(target) + " >= accessor count " + str(l.count) + " (accessor " + str(index) + ")");
        for (size_t c = 0; c < components; c++)
            out[target * components + c] = static_cast<T>(
                read_component(l.sparse_values + k * l.element_size + c * csize, l.component_type, l.normalized));
    }
    return out;
}

// ---------------- transforms

struct Mat4 {
    double m[16];  // column-major, as glTF stores it: element (row r, column c) is m[c*4 + r]
    double at(int r, int c) const { return m[c * 4 + r]; }
};

Mat4 identity() {
    Mat4 i = {{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1}};
    return i;
}

Mat4 multiply(const Mat4 &a, const Mat4 &b) {
    Mat4 r;
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            double s = 0;
            for (int k = 0; k < 4; k++) s += a.at(row, k) * b.at(k, c);
            r.m[c * 4 + row] = s;
        }
    return r;
}

bool all_finite(const std::vector<double> &v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// The node's local matrix: `matrix`, else T * R * S. Lengths and finiteness are checked here.
// T * R * S, glTF's order, for a unit quaternion q (x, y, z, w).
Mat4 trs_matrix(const double t[3], const double q[4], const double s[3]) {
    Mat4 out = identity();
    double x = q[0], y = q[1], z = q[2], w = q[3];
    double r[3][3] = {{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)},
                      {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)},
                      {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)}};
    for (int row = 0; row < 3; row++)
        for (int c = 0; c < 3; c++) out.m[c * 4 + row] = r[row][c] * s[c];
    for (int row = 0; row < 3; row++) out.m[12 + row] = t[row];
    return out;
}

Mat4 local_matrix(const tinygltf::Node &node, int index) {
    std::string where = " (node " + str(index) + ")";
    struct { const std::vector<double> &values; size_t size; const char *name; } parts[] = {
        {node.matrix, 16, "matrix"}, {node.translation, 3, "translation"}, {node.rotation, 4, "rotation"},
        {node.scale, 3, "scale"}};
    for (const auto &p : parts) {
        if (!p.values.empty() && p.values.size() != p.size)
            fail(std::string(p.name) + " must have " + str(p.size) + " numbers, got " + str(p.values.size()) + where);
        if (!all_finite(p.values)) fail(std::string("non-finite ") + p.name + where);
    }
    Mat4 out = identity();
    if (!node.matrix.empty()) {
        // glTF: a node matrix is affine (decomposable into TRS), its last row [0 0 0 1]; the
        // renderer reads the upper 3x4 alone, so another row would be silently dropped
        const std::vector<double> &m = node.matrix;
        if (std::fabs(m[3]) > 1e-6 || std::fabs(m[7]) > 1e-6 || std::fabs(m[11]) > 1e-6 || std::fabs(m[15] - 1) > 1e-6)
            fail("matrix's last row is [" + num(m[3]) + " " + num(m[7]) + " " + num(m[11]) + " " + num(m[15]) +
                 "], not [0 0 0 1] (glTF node matrices are affine)" + where);
        std::copy(node.matrix.begin(), node.matrix.end(), out.m);
        return out;
    }
    double q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    if (!node.rotation.empty()) {
        double len = std::sqrt(node.rotation[0] * node.rotation[0] + node.rotation[1] * node.rotation[1] +
                               node.rotation[2] * node.rotation[2] + node.rotation[3] * node.rotation[3]);
        if (!(len > 0) || !std::isfinite(len)) fail("rotation quaternion has zero or infinite length" + where);
        for (int i = 0; i < 4; i++) q[i] = node.rotation[i] / len;
    }
    if (!node.scale.empty()) std::copy(node.scale.begin(), node.scale.end(), s);
    double t[3] = {0, 0, 0};
    if (!node.translation.empty()) std::copy(node.translation.begin(), node.translation.end(), t);
    return trs_matrix(t, q, s);
}

// The world-space quantities one node instance needs: point and direction transforms, the
// inverse-transpose for normals, and whether it mirrors (negative determinant).
struct WorldTransform {
    Mat4 matrix;
    double normal_matrix[3][3];
    bool mirrored;

    explicit WorldTransform(const Mat4 &m) : matrix(m) {
        double cof[3][3];
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                int r1 = (r + 1) % 3, r2 = (r + 2) % 3, c1 = (c + 1) % 3, c2 = (c + 2) % 3;
                cof[r][c] = m.at(r1, c1) * m.at(r2, c2) - m.at(r1, c2) * m.at(r2, c1);
            }
        double det = m.at(0, 0) * cof[0][0] + m.at(0, 1) * cof[0][1] + m.at(0, 2) * cof[0][2];
        mirrored = det < 0;
        // inverse-transpose = cofactor / det; a singular matrix keeps the cofactor's direction
        double scale = (det != 0 && std::isfinite(det)) ? 1.0 / det : 1.0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) normal_matrix[r][c] = cof[r][c] * scale;
    }
    vec3 point(const float *p) const {
        double out[3];
        for (int r = 0; r < 3; r++)
            out[r] = matrix.at(r, 0) * p[0] + matrix.at(r, 1) * p[1] + matrix.at(r, 2) * p[2] + matrix.at(r, 3);
        return v3(static_cast<float>(out[0]), static_cast<float>(out[1]), static_cast<float>(out[2]));
    }
    // A unit direction, or (0,0,0) when the transform collapses it.
    vec3 unit(const double d[3], bool is_normal) const {
        double out[3];
        for (int r = 0; r < 3; r++)
            out[r] = is_normal ? normal_matrix[r][0] * d[0] + normal_matrix[r][1] * d[1] + normal_matrix[r][2] * d[2]
                               : matrix.at(r, 0) * d[0] + matrix.at(r, 1) * d[1] + matrix.at(r, 2) * d[2];
        double len = std::sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
        if (!(len > 0) || !std::isfinite(len)) return v3(0, 0, 0);
        return v3(static_cast<float>(out[0] / len), static_cast<float>(out[1] / len), static_cast<float>(out[2] / len));
    }
    // How much the transform stretches a direction (0 when it collapses it).
    double stretch(const double d[3]) const {
        double out[3];
        for (int r = 0; r < 3; r++) out[r] = matrix.at(r, 0) * d[0] + matrix.at(r, 1) * d[1] + matrix.at(r, 2) * d[2];
        return std::sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
    }
    vec3 origin() const {
        const float zero[3] = {0, 0, 0};
        return point(zero);
    }
};

// ---------------- the loader's types and the Loader class

struct DecodedPrimitive {
    bool triangles = false;             // false: points or lines, skipped
    uint64_t flat_triangles = 0;        // triangles with a corner whose NORMAL is unusable: they get their own vertices
    std::vector<float> positions;       // 3 per vertex, mesh space
    std::vector<float> normals, uvs, uvs1;  // empty when the primitive has none (uvs1: or no texture reads it)
    std::vector<float> tangents;        // TANGENT, 4 per vertex; empty when absent or no material has a normal map
    std::vector<uint32_t> corners;      // 3 per triangle, glTF winding
    uint32_t material = 0;
};

struct DecodedMesh {
    std::vector<DecodedPrimitive> primitives;
    uint64_t vertices = 0, triangles = 0;  // per instance, before degenerate triangles are dropped
};

// One primitive placed through one transform (instance_mesh): its vertices in world space and
// how its tangents are made.
struct PlacedPrimitive {
    explicit PlacedPrimitive(const DecodedPrimitive &p) : prim(p) {}
    const DecodedPrimitive &prim;
    std::vector<vec3> positions, normals;  // world space; normals empty without NORMAL
    bool flat = false;                     // no NORMAL, or none keeps a direction
    bool has_uv = false, has_uv1 = false;
    bool mapped = false;                   // a normal map reads the tangents
    bool given_tangents = false;           // from TANGENT, else generated
    const std::vector<float> *tangent_uvs = nullptr;  // the normal texture's UV set
    std::vector<float> tangents;           // given: 4 per vertex in world space
    std::vector<vec3> du_sum;              // generated: per shared vertex, its triangles' dp/du
    std::vector<double> hand_sum;          // and handedness votes
    uint32_t base = 0;                     // the first shared vertex's index in the scene's arrays
};

// A mesh placed by a node: by the node itself, or (EXT_mesh_gpu_instancing) by element `element`
// of the node's instance set `set` on top of the node's transform.
struct Instance {
    int node, mesh;
    int set = -1;
    uint32_t element = 0;
};

// A node's EXT_mesh_gpu_instancing attributes, read and checked: per instance a translation, a
// unit rotation quaternion and a scale (absent attributes read as the identity's).
struct InstanceSet {
    int node;
    std::vector<float> translation, rotation, scale;  // 3, 4 and 3 per instance, or empty
};

// A textureInfo as written (checked in the preflight): its texture, TEXCOORD set and KHR_texture_transform.
struct TextureReference {
    int texture = -1;  // glTF texture index, -1 none
    uint64_t texcoord = 0;  // after the transform's texCoord override
    bool transformed = false;
    double offset[2] = {0, 0}, rotation = 0, scale[2] = {1, 1};
};

// The texture references pmview renders, per material.
enum {
    kBaseColor, kEmissive, kMetallicRoughness, kTransmission, kNormal,
    kSpecular, kSpecularColor, kSheenColor, kSheenRoughness, kClearcoat, kClearcoatRoughness, kClearcoatNormal,
    kReferenceKinds
};

// Owns the malloc'ed texels until the scene takes them.
struct TextureList {
    std::vector<pm_texture> items;
    ~TextureList() {
        for (pm_texture &t : items) free(t.rgba);
    }
};

// What tinygltf's parsers share while build_model fills the Model: the guarded file-system hooks,
// the image decoder, and the errors and warnings they append to.
struct ModelParse {
    static constexpr bool kKeepJson = false;  // tinygltf's copies of extensions and extras as text: nothing reads them
    tinygltf::FsCallbacks fs;
    tinygltf::LoadImageDataFunction image_loader;
    std::string error, warning;
};

class Loader {
public:
    explicit Loader(const std::string &path) : path_(path) {
        size_t slash = path.find_last_of('/');
        folder_ = slash == std::string::npos ? "" : path.substr(0, slash == 0 ? 1 : slash);
        hooks_.folder = lexical_normal(folder_);
    }
    // Bytes already in memory; path_ only names them (messages, the .glb extension).
    Loader(const std::string &name, const unsigned char *data, size_t size) : Loader(name) {
        memory_ = data;
        memory_size_ = size;
        hooks_.no_files = true;
    }
    void set_options(const pm_load_options &options) { options_ = options; }

    void load(pm_scene *out);
    const std::vector<std::string> &warnings() const { return warnings_; }
    uint32_t skipped_degenerate() const { return static_cast<uint32_t>(std::min<uint64_t>(degenerate_, UINT32_MAX)); }
    uint32_t skipped_primitives() const { return static_cast<uint32_t>(std::min<uint64_t>(skipped_prims_, UINT32_MAX)); }
    uint32_t ignored_inputs() const { return ignored_inputs_; }
    uint32_t occlusion_textures_ignored() const { return occlusion_textures_ignored_; }
    double unit_scale() const { return frame_scale_; }
    uint32_t json_parses() const { return json_parses_; }
    double json_seconds() const { return json_seconds_; }
    bool recentered() const { return recentered_; }
    // The largest memory the load held at once, forecast from the sizes it met (see forecast_phase).
    uint64_t forecast_peak() const { return forecast_peak_; }

private:
    // validation (stage 1)
    std::vector<unsigned char> read_model_file();
    void split_container(const std::vector<unsigned char> &file);
    void model_from_json();
    json parse_json();
    void preflight(const json &root);
    void preflight_asset_and_extensions(const json &root);
    void preflight_counts(const json &root);
    void preflight_buffers(const json &root);
    std::vector<uint64_t> preflight_buffer_views(const json &root);
    void preflight_accessors(const json &root);
    std::vector<int> preflight_images_and_textures(const json &root, const std::vector<uint64_t> &view_lengths);
    void preflight_material_references(const json &root, const std::vector<int> &texture_sources);
    void preflight_meshes(const json &root);
    void preflight_nodes_and_scenes(const json &root);
    void preflight_typed_members(const json &root);
    void preflight_other_indices(const json &root);
    void preflight_uri_target(const json &object, const std::string &where, bool is_buffer, uint64_t byte_length);
    void preflight_compressed(const json &root);
    // model building (stage 2)
    void build_model(const json &root);
    bool parse_model_geometry(const json &root, ModelParse &parse);
    bool mark_buffer_view_targets(ModelParse &parse);
    bool parse_model_nodes_and_materials(const json &root, ModelParse &parse);
    bool parse_model_images(const json &root, ModelParse &parse);
    bool parse_model_remaining(const json &root, ModelParse &parse);
    void check_model_counts();
    void decode_compressed();
    void admit_decoded(uint64_t bytes, const std::string &where);
    int own_buffer(std::vector<unsigned char> &&bytes);
    void decode_meshopt_views();
    std::vector<char> meshes_in_default_scene() const;
    void decode_draco_primitives();
    // One Draco primitive's stream (its bufferView), where it is for messages, the accessors
    // already filled (each by one stream) and the decoders' message buffer.
    struct DracoFill {
        int view;
        std::string where;
        std::map<int, int> *filled_from;
        char *message;
        size_t message_size;
    };
    void fill_from_draco(const DracoFill &fill, int accessor, uint64_t count, const char *what,
                         const std::function<bool(void *)> &decode);
    // the scene: graph, materials, geometry, instancing, frame (stage 3)
    void traverse_default_scene();
    const DecodedMesh &decoded_mesh(int mesh);
    DecodedPrimitive decode_primitive(int mesh, int primitive);
    // The primitive being decoded: which it is, its glTF description, where it is for messages.
    struct PrimitiveSource {
        int mesh, index;
        const tinygltf::Primitive &prim;
        std::string where;
        size_t vertices;  // POSITION's count, once read
    };
    size_t read_positions(const PrimitiveSource &source, DecodedPrimitive *out);
    void read_vertex_attributes(const PrimitiveSource &source, DecodedPrimitive *out);
    void apply_morph_targets(const PrimitiveSource &source, DecodedPrimitive *out);
    void round_tangent_signs(const PrimitiveSource &source, DecodedPrimitive *out);
    std::vector<uint32_t> read_index_sequence(const PrimitiveSource &source);
    void assemble_corners(const tinygltf::Primitive &prim, const std::vector<uint32_t> &sequence, const std::string &where,
                          DecodedPrimitive *out);
    void flatten_unusable_normals(const PrimitiveSource &source, DecodedPrimitive *out);
    void instance_mesh(const Instance &instance, const Mat4 &transform);
    void place_vertices(PlacedPrimitive *placed, const WorldTransform &world, const std::string &where);
    void place_tangents(PlacedPrimitive *placed, const WorldTransform &world);
    void append_vertex(const PlacedPrimitive &placed, size_t i, vec3 normal);
    void place_triangle(PlacedPrimitive *placed, bool mirrored, size_t t);
    void add_light(int light, const WorldTransform &world, int node);
    void choose_frame();
    struct PlacedBounds {
        double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
        uint64_t triangles = 0;
        double smallest = INFINITY;  // the narrowest triangle's extent (largest axis of its bounds), degenerate ones aside
    };
    PlacedBounds placed_bounds() const;
    void frame_attenuation();
    void add_camera(int camera, const WorldTransform &world, int node);
    void convert_materials();
    void apply_variant();
    int texture_for(int gltf_texture, const std::string &where);
    void sampler_filters(const tinygltf::Sampler &s, int sampler, pm_texture *tex);
    bool convert_reference(const TextureReference &r, const std::string &where, int *texture, int *texcoord,
                           pm_uv_transform *transform);
    double checked(double value, double lo, double hi, const char *field, const std::string &object);
    vec3 emission_within_film(const double hue[3], double magnitude, const char *field, const std::string &made_of,
                              const std::string &object);
    bool volume_attenuation(const tinygltf::ExtensionMap &extensions, const std::string &object, double sigma[3]);
    bool convert_layers(const tinygltf::Material &mat, const std::array<TextureReference, kReferenceKinds> &refs,
                        const std::string &label, const std::string &name, pm_material *m);
    std::string material_label(size_t material) const;
    std::string mesh_label(int mesh, int primitive) const;
    // Stores vertex i's generated tangent: dp/du made unit and perpendicular to the normal, or
    // any perpendicular when the UV mapping gives none there.
    void set_tangent(size_t i, vec3 du, vec3 normal, float hand) {
        float largest = std::max(std::fabs(du.x), std::max(std::fabs(du.y), std::fabs(du.z)));
        if (largest > 0.f && std::isfinite(largest)) du = v3_scale(du, 1.f / largest);  // its square stays in range
        vec3 t = v3_sub(du, v3_scale(normal, v3_dot(du, normal)));
        float len = v3_length(t);
        if (len > 1e-12f && std::isfinite(len)) {
            t = v3_scale(t, 1.f / len);
        } else {
            vec3 unused;
            v3_basis(normal, &t, &unused);
        }
        float *out = &tangents_[4 * i];
        out[0] = t.x;
        out[1] = t.y;
        out[2] = t.z;
        out[3] = hand;
    }
    void emit(pm_scene *out);
    // The load's peak is met in one of two places: while the JSON document is alive beside the
    // file and tinygltf's model, or in emit(), where the scene's arrays exist twice (the vectors
    // and their copies) beside the file, the model, the decoded meshes and the texels.
    void forecast_phase(uint64_t bytes) { forecast_peak_ = std::max(forecast_peak_, bytes); }
    uint64_t model_bytes() const;
    uint64_t decoded_bytes() const;
    uint64_t output_bytes() const;

    void warn(const std::string &message) { warnings_.push_back(message); }
    // A clamped or replaced value: one warning per object and field, the first value's; later
    // ones only count (unless they are the same value met again), and the warning ends with
    // their number (see finish_notes).
    void note(const std::string &object, const std::string &field, const std::string &what, bool count_repeats = true) {
        auto it = noted_.find(object + '\n' + field);
        if (it != noted_.end()) {
            it->second.repeats += count_repeats;
            return;
        }
        noted_[object + '\n' + field] = {warnings_.size(), 0};
        warn(object + " " + field + " " + what);
    }
    void finish_notes() {
        for (const auto &n : noted_)
            if (n.second.repeats) warnings_[n.second.warning] += " (and " + str(n.second.repeats) + " more of its values)";
    }

    std::string path_, folder_;
    const unsigned char *memory_ = nullptr;  // non-null: load these bytes instead of reading path_
    size_t memory_size_ = 0;
    std::vector<std::string> warnings_;

    // container
    bool binary_ = false;
    const char *json_text_ = nullptr;
    size_t json_size_ = 0, bin_size_ = 0;
    bool has_bin_ = false;
    const unsigned char *bin_data_ = nullptr;  // the BIN chunk's bytes, inside the file's
    uint64_t file_bytes_ = 0, forecast_peak_ = 0;
    uint32_t json_parses_ = 0;  // texts parsed into a JSON document (one per load: see model_from_json)
    double json_seconds_ = 0;

    // preflight results
    size_t count_scenes_ = 0, count_nodes_ = 0, count_meshes_ = 0, count_accessors_ = 0, count_views_ = 0,
           count_buffers_ = 0, count_materials_ = 0, count_textures_ = 0, count_images_ = 0, count_samplers_ = 0,
           count_cameras_ = 0, count_skins_ = 0, count_lights_ = 0;
    std::vector<size_t> primitives_per_mesh_;
    std::vector<uint64_t> buffer_lengths_;
    TinygltfHooks hooks_;
    Model model_;
    // Compressed geometry the preflight found, decoded by decode_compressed into buffers of its own.
    struct MeshoptView { int view, buffer, mode, filter; uint64_t offset, length, count, stride; };
    std::vector<MeshoptView> meshopt_views_;
    std::vector<bool> fallback_buffers_;  // per buffer: an EXT_meshopt_compression fallback without data
    struct DracoPrimitive { int mesh, primitive, view; std::vector<std::pair<int, uint32_t>> accessor_ids; };
    std::vector<DracoPrimitive> draco_primitives_;
    Admitted decoded_;  // the decoded buffers' bytes, given back with the Model

    // conversion
    std::vector<Mat4> world_;  // per node, valid once the traversal reached it
    std::vector<Instance> instances_;
    std::vector<InstanceSet> instance_sets_;  // EXT_mesh_gpu_instancing, per node that has it
    uint64_t zero_scale_instances_ = 0;       // GPU instances left out: a zero scale places nothing
    std::string first_zero_scale_;
    void read_instance_set(int node_index, const tinygltf::Node &node, const tinygltf::Value &extension);
    Mat4 instance_world(const Instance &instance) const;
    // instancing (scene.h): meshes placed by two or more nodes are stored once and placed
    pm_load_options options_ = {};
    std::vector<pm_instanced_mesh> instanced_meshes_;
    std::vector<pm_placement> placements_;
    uint64_t triangle_ids_ = 0;
    void place_instanced_meshes(const std::vector<uint32_t> &uses);
    std::vector<uint32_t> decode_placed_meshes();
    std::vector<char> choose_instanced_meshes(const std::vector<uint32_t> &uses) const;
    struct SceneTotals { uint64_t vertices = 0, triangles = 0, placements = 0; };  // stored, after instancing
    SceneTotals count_scene(const std::vector<char> &instanced);
    void admit_scene_geometry(const SceneTotals &totals);
    void add_default_material();
    void check_something_to_render() const;
    void warn_load_counts();
    bool framed_alone(size_t mesh) const;
    struct Placed { int node, index; bool light; };
    std::vector<Placed> placed_;  // cameras and lights in traversal order
    // The frame the scene is stored in: world = (file world - frame_center_) x frame_scale_ (see choose_frame)
    double frame_scale_ = 1, frame_center_[3] = {0, 0, 0};
    bool recentered_ = false;
    std::vector<std::unique_ptr<DecodedMesh>> meshes_;
    std::vector<pm_material> materials_;
    bool default_material_used_ = false;
    TextureList textures_;
    Admitted admitted_;  // the textures' texels and the geometry, until emit() hands them to the scene
    std::map<int, int> texture_of_gltf_;
    std::map<std::string, int> texture_of_image_;  // (the pm_texture's sampling fields, image) -> its index
    std::vector<pm_light> lights_;
    std::vector<pm_camera> cameras_;
    std::vector<char> variant_names_;  // KHR_materials_variants' names, each ended by '\0' (pm_scene.variant_names)
    uint32_t variant_count_ = 0;
    std::vector<vec3> positions_, normals_;
    std::vector<float> uvs_, uvs1_;
    bool any_uv_ = false, any_uv1_ = false;
    bool uv1_needed_ = false;   // some rendered texture reads TEXCOORD_1
    bool tangents_needed_ = false; // some material has a normal map: vertices keep a tangent
    std::vector<float> tangents_;  // 4 per vertex when tangents_needed_
    bool quantization_ = false; // KHR_mesh_quantization is used: integer vertex attributes are allowed
    std::vector<std::array<TextureReference, kReferenceKinds>> references_;  // per material
    std::vector<uint32_t> indices_, triangle_material_;
    uint64_t degenerate_ = 0, skipped_prims_ = 0;
    struct Noted { size_t warning; uint64_t repeats; };
    std::map<std::string, Noted> noted_;  // object and field -> its warning (see note)
    std::vector<std::array<double, 3>> attenuation_;  // per material, per unit length of the file, framed in choose_frame
    uint64_t collapsed_normals_ = 0;  // usable NORMAL values the node's transform reduced to nothing
    std::string first_collapsed_;
    bool node_weights_warned_ = false;
    uint64_t nonfinite_uvs_ = 0;      // NaN or infinite texture coordinates, read as 0
    std::string first_nonfinite_uv_;
    uint32_t ignored_inputs_ = 0;  // materials using an input pmview does not render (each kind warned once)
    // Occlusion textures stand in for what a rasteriser cannot compute; tracing computes it, so
    // they are left out by design: counted for --stats, never warned about.
    uint32_t occlusion_textures_ignored_ = 0;
    struct Ignored { uint32_t count; std::string first; };
    std::map<std::string, Ignored> ignored_;  // kind -> materials using it, the first one's name
    void note_ignored(const std::string &kind, const std::string &material) {
        Ignored &i = ignored_[kind];
        if (i.count++ == 0) i.first = material;
        ignored_inputs_++;
    }
};

// ---------------- validation: the file, its container and JSON, the preflight's checks

std::vector<unsigned char> Loader::read_model_file() {
    if (memory_) {
        if (memory_size_ == 0) fail("empty file");
        if (memory_size_ > UINT32_MAX) fail("file too large (tinygltf reads at most 4 GiB)");
        return std::vector<unsigned char>(memory_, memory_ + memory_size_);
    }
    struct stat st;
    if (stat(path_.c_str(), &st) != 0) fail(std::string("cannot open: ") + strerror(errno));
    if (!S_ISREG(st.st_mode)) fail("not a regular file");  // before fopen, which would wait on a FIFO
    std::unique_ptr<FILE, int (*)(FILE *)> f(fopen(path_.c_str(), "rb"), fclose);
    if (!f || fstat(fileno(f.get()), &st) != 0) fail(std::string("cannot open: ") + strerror(errno));
    if (st.st_size == 0) fail("empty file");
    if (static_cast<uint64_t>(st.st_size) > UINT32_MAX) fail("file too large (tinygltf reads at most 4 GiB)");
    std::vector<unsigned char> data(static_cast<size_t>(st.st_size));
    if (fread(data.data(), 1, data.size(), f.get()) != data.size()) fail(std::string("read error: ") + strerror(errno));
    return data;
}

uint32_t read_u32(const unsigned char *p) {
    return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
           static_cast<uint32_t>(p[3]) << 24;
}

void Loader::split_container(const std::vector<unsigned char> &file) {
    std::string ext = path_.size() >= 4 ? path_.substr(path_.size() - 4) : "";
    for (char &c : ext) c = static_cast<char>(tolower(static_cast<unsigned char>(c)));
    binary_ = ext == ".glb" || (file.size() >= 4 && memcmp(file.data(), "glTF", 4) == 0);
    if (!binary_) {
        json_text_ = reinterpret_cast<const char *>(file.data());
        json_size_ = file.size();
        return;
    }
    const uint64_t size = file.size();
    if (size < 12) fail("not a glTF binary (file shorter than the 12-byte GLB header)");
    if (memcmp(file.data(), "glTF", 4) != 0) fail("not a glTF binary (bad magic)");
    uint32_t version = read_u32(&file[4]), length = read_u32(&file[8]);
    if (version != 2) fail("unsupported GLB version " + str(version));
    if (length > size) fail("truncated GLB: header length " + str(length) + " > file size " + str(size));
    if (length != size) fail("GLB header length " + str(length) + " != file size " + str(size));
    uint64_t offset = 12;
    for (int chunk = 0; offset < size; chunk++) {
        if (size - offset < 8) fail("truncated GLB: chunk " + str(chunk) + " header extends past end of file");
        uint64_t chunk_length = read_u32(&file[offset]), type = read_u32(&file[offset + 4]);
        if (chunk_length > size - offset - 8)
            fail("truncated GLB: chunk " + str(chunk) + " (" + str(chunk_length) + " bytes) extends past end of file");
        // the GLB specification: every chunk starts and ends on a 4-byte boundary; one JSON chunk,
        // first, and at most one BIN chunk, second (chunks of other types are ignored)
        if (chunk_length % 4 != 0)
            fail("GLB chunk " + str(chunk) + " length " + str(chunk_length) + " is not a multiple of 4");
        if (chunk >= 2 && (type == 0x4E4F534Au || type == 0x004E4942u))
            fail("GLB chunk " + str(chunk) + " is a second " + (type == 0x004E4942u ? "BIN" : "JSON") + " chunk");
        const unsigned char *payload = &file[offset + 8];
        if (chunk == 0) {
            if (type != 0x4E4F534Au) fail("GLB chunk 0 is not JSON");
            if (chunk_length == 0) fail("GLB JSON chunk is empty");
            json_text_ = reinterpret_cast<const char *>(payload);
            json_size_ = chunk_length;
        } else if (chunk == 1) {
            // tinygltf reads the second chunk as BIN and refuses anything else
            if (type != 0x004E4942u) fail("GLB chunk 1 is not BIN");
            if (chunk_length < 4 || chunk_length % 4 != 0)
                fail("GLB BIN chunk length " + str(chunk_length) + " is not a positive multiple of 4");
            has_bin_ = true;
            bin_data_ = payload;
            bin_size_ = chunk_length;
        }
        offset += 8 + chunk_length;
    }
    if (!json_text_) fail("truncated GLB: no JSON chunk");
}

// The JSON text becomes a document once: the preflight checks that document and tinygltf's Model is
// built from it, so no check can pass on one reading of the text and the Model come from another.
void Loader::model_from_json() {
    // the parsed document and tinygltf's copy of its objects, admitted while they live: a file of
    // 10^6 lights parsed to gigabytes under --max-memory 64M (28 bytes a byte of JSON measured for
    // 2x10^5 lights). A text under 1 MiB is left to the process's baseline, as the code is: its
    // document is a few megabytes at most, and a small --max-memory still names what it is for.
    uint64_t document = json_size_ >= (1u << 20) ? 3 * PM_JSON_DOCUMENT_BYTES_PER_BYTE * static_cast<uint64_t>(json_size_) : 0;
    const uint64_t mark = pm_memory_failure_mark();
    if (!pm_memory_admit(document, "JSON document"))
        fail("out of memory (" + std::string(pm_memory_failure_since_or(mark, "JSON document")) + ") parsing " + str(json_size_) +
             " bytes of JSON");
    struct Release {
        uint64_t bytes;
        ~Release() { pm_memory_release(bytes); }
    } release{document};
    json root = parse_json();
    preflight(root);
    build_model(root);
    forecast_phase(file_bytes_ + PM_JSON_DOCUMENT_BYTES_PER_BYTE * json_size_ + model_bytes());
}  // the document goes here, before the conversion allocates the scene

json Loader::parse_json() {
    if (json_depth(json_text_, json_size_) > kMaxJsonDepth)
        fail("JSON nested deeper than " + str(kMaxJsonDepth) + " levels");
    auto start = std::chrono::steady_clock::now();
    json_parses_++;
    try {
        json root = json::parse(json_text_, json_text_ + json_size_);
        json_seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        return root;
    } catch (const json::exception &e) {
        fail("JSON syntax error: " + one_line(e.what()));
    }
}

// A number member of KHR_texture_transform, or a fixed-size array of them; absent keeps the default.
void transform_numbers(const json &ext, const char *key, double *out, size_t n, const std::string &where) {
    const json *v = find_member(ext, key);
    if (!v) return;
    bool ok = n == 1 ? v->is_number() : (v->is_array() && v->size() == n);
    for (size_t i = 0; ok && i < n; i++) {
        const json &x = n == 1 ? *v : (*v)[i];
        ok = x.is_number() && std::isfinite(x.get<double>());
        if (ok) out[i] = x.get<double>();
    }
    if (!ok)
        fail(std::string("KHR_texture_transform ") + key + " must be " + (n == 1 ? "a number" : str(n) + " numbers") +
             ", got " + describe(*v) + " (" + where + ")");
}

// textureInfo.extensions.KHR_texture_transform into r, its texCoord overriding the textureInfo's.
void read_texture_transform(const json &info, const std::string &where, TextureReference *r) {
    const json *extensions = find_member(info, "extensions");
    const json *ext = extensions ? find_member(*extensions, "KHR_texture_transform") : nullptr;
    if (!ext) return;
    std::string sub = where + " KHR_texture_transform";
    if (!ext->is_object()) fail("KHR_texture_transform is not an object (" + where + ")");
    transform_numbers(*ext, "offset", r->offset, 2, where);
    transform_numbers(*ext, "rotation", &r->rotation, 1, where);
    transform_numbers(*ext, "scale", r->scale, 2, where);
    r->texcoord = unsigned_member(*ext, "texCoord", false, r->texcoord, INT_MAX, sub);
    r->transformed = r->offset[0] != 0 || r->offset[1] != 0 || r->rotation != 0 || r->scale[0] != 1 || r->scale[1] != 1;
}

void Loader::preflight(const json &root) {
    preflight_asset_and_extensions(root);
    preflight_counts(root);
    preflight_buffers(root);
    std::vector<uint64_t> view_lengths = preflight_buffer_views(root);
    preflight_accessors(root);
    std::vector<int> texture_sources = preflight_images_and_textures(root, view_lengths);
    preflight_material_references(root, texture_sources);
    preflight_meshes(root);
    preflight_nodes_and_scenes(root);
    preflight_other_indices(root);
    preflight_typed_members(root);
    preflight_compressed(root);
}

bool extension_supported(const std::string &name) {
    return std::find(std::begin(kSupportedExtensions), std::end(kSupportedExtensions), name) !=
           std::end(kSupportedExtensions);
}

// asset.version, the required extensions (each supported) and the used ones pmview ignores.
void Loader::preflight_asset_and_extensions(const json &root) {
    if (!root.is_object()) fail("the JSON root is not an object");
    const json *asset = find_member(root, "asset");
    const json *version = asset ? find_member(*asset, "version") : nullptr;
    if (!version || !version->is_string()) fail("missing asset.version (asset)");
    std::string v = version->get<std::string>();
    if (v.compare(0, 2, "2.") != 0) fail("unsupported glTF version " + printable(v) + " (asset.version)");

    const json &required = optional_array(root, "extensionsRequired", "top level");
    for (const json &e : required) {
        if (!e.is_string()) fail("extensionsRequired holds " + describe(e) + ", not a name");
        if (!extension_supported(e.get<std::string>()))
            fail("required extension " + printable(e.get<std::string>()) + " is not supported");
    }
    std::string ignored;
    int ignored_count = 0;
    for (const json &e : required)
        if (e.get<std::string>() == "KHR_mesh_quantization") quantization_ = true;
    for (const json &e : optional_array(root, "extensionsUsed", "top level")) {
        if (e.is_string() && e.get<std::string>() == "KHR_mesh_quantization") quantization_ = true;
        if (!e.is_string() || extension_supported(e.get<std::string>())) continue;
        if (ignored_count++ < 8) ignored += (ignored.empty() ? "" : ", ") + printable(e.get<std::string>());
    }
    if (ignored_count)
        warn("ignoring unsupported extension(s) " + ignored + (ignored_count > 8 ? ", ..." : "") +
             " (used, not required)");
}

// The top-level arrays' sizes, first: every index the preflight meets is checked against them.
void Loader::preflight_counts(const json &root) {
    count_scenes_ = optional_array(root, "scenes", "top level").size();
    count_nodes_ = optional_array(root, "nodes", "top level").size();
    count_meshes_ = optional_array(root, "meshes", "top level").size();
    count_accessors_ = optional_array(root, "accessors", "top level").size();
    count_views_ = optional_array(root, "bufferViews", "top level").size();
    count_buffers_ = optional_array(root, "buffers", "top level").size();
    count_materials_ = optional_array(root, "materials", "top level").size();
    count_textures_ = optional_array(root, "textures", "top level").size();
    count_images_ = optional_array(root, "images", "top level").size();
    count_samplers_ = optional_array(root, "samplers", "top level").size();
    count_cameras_ = optional_array(root, "cameras", "top level").size();
    count_skins_ = optional_array(root, "skins", "top level").size();
    const json *root_ext = find_member(root, "extensions");
    const json *lights_ext = root_ext ? find_member(*root_ext, "KHR_lights_punctual") : nullptr;
    if (lights_ext) count_lights_ = optional_array(*lights_ext, "lights", "KHR_lights_punctual").size();
}

// Each bufferView inside its buffer, with a valid byteStride; returns their byteLengths.
std::vector<uint64_t> Loader::preflight_buffer_views(const json &root) {
    std::vector<uint64_t> view_lengths;
    for_each_object(root, "bufferViews", "bufferView", [&](const json &bv, const std::string &where, size_t i) {
        int buffer = required_index(bv, "buffer", count_buffers_, "buffer", where);
        uint64_t offset = unsigned_member(bv, "byteOffset", false, 0, UINT64_MAX, where);
        uint64_t length = unsigned_member(bv, "byteLength", true, 0, UINT64_MAX, where);
        if (length == 0) fail("byteLength 0: a bufferView holds at least 1 byte (" + where + ")");
        uint64_t available = buffer_lengths_[buffer];
        if (offset > available || length > available - offset)
            fail("bufferView " + str(i) + " (offset " + str(offset) + " + length " + str(length) + ") exceeds buffer " +
                 str(buffer) + " (" + str(available) + " bytes)");
        if (find_member(bv, "byteStride")) {
            uint64_t stride = unsigned_member(bv, "byteStride", true, 0, 252, where);
            if (stride < 4 || stride % 4 != 0)
                fail("byteStride " + str(stride) + " is not a multiple of 4 in [4, 252] (" + where + ")");
        }
        view_lengths.push_back(length);
    });
    return view_lengths;
}

// Each accessor's members and its sparse substitution's (their ranges are checked in accessor_layout).
void Loader::preflight_accessors(const json &root) {
    for_each_object(root, "accessors", "accessor", [&](const json &a, const std::string &where, size_t) {
        optional_index(a, "bufferView", count_views_, "bufferView", where);
        unsigned_member(a, "byteOffset", false, 0, UINT64_MAX, where);
        unsigned_member(a, "count", true, 0, UINT64_MAX, where);
        uint64_t type = unsigned_member(a, "componentType", true, 0, UINT32_MAX, where);
        if (component_size(static_cast<int>(type)) == 0)
            fail("unsupported componentType " + str(type) + " (" + where + ")");
        const json *sparse = find_member(a, "sparse");
        if (!sparse) return;
        if (!sparse->is_object()) fail("sparse is not an object (" + where + ")");
        unsigned_member(*sparse, "count", true, 0, INT_MAX, where + " sparse");
        for (const char *part : {"indices", "values"}) {
            std::string sub = where + " sparse " + part;
            const json *p = find_member(*sparse, part);
            if (!p || !p->is_object()) fail("missing sparse " + std::string(part) + " object (" + where + ")");
            required_index(*p, "bufferView", count_views_, "bufferView", sub);
            unsigned_member(*p, "byteOffset", false, 0, INT_MAX, sub);
        }
        unsigned_member(*find_member(*sparse, "indices"), "componentType", true, 0, UINT32_MAX, where + " sparse indices");
    });
}

// Images, samplers and textures; returns each texture's image (-1 none).
std::vector<int> Loader::preflight_images_and_textures(const json &root, const std::vector<uint64_t> &view_lengths) {
    for_each_object(root, "images", "image", [&](const json &image, const std::string &where, size_t) {
        int view = optional_index(image, "bufferView", count_views_, "bufferView", where);
        if (view >= 0 && view_lengths[view] > static_cast<uint64_t>(INT_MAX))
            fail("image data over 2 GiB (" + where + ")");  // tinygltf passes its size as an int
        preflight_uri_target(image, where, false, 0);
    });

    for_each_object(root, "samplers", "sampler", [&](const json &s, const std::string &where, size_t) {
        unsigned_member(s, "wrapS", false, 0, INT_MAX, where);
        unsigned_member(s, "wrapT", false, 0, INT_MAX, where);
        unsigned_member(s, "magFilter", false, 0, INT_MAX, where);
        unsigned_member(s, "minFilter", false, 0, INT_MAX, where);
    });

    hooks_.image_wanted.assign(count_images_, 0);
    std::vector<int> texture_sources;
    for_each_object(root, "textures", "texture", [&](const json &t, const std::string &where, size_t) {
        texture_sources.push_back(optional_index(t, "source", count_images_, "image", where));
        optional_index(t, "sampler", count_samplers_, "sampler", where);
    });
    return texture_sources;
}

// Every material's texture references, kept per material (references_); the images they reach
// are the ones load_wanted_image decodes.
void Loader::preflight_material_references(const json &root, const std::vector<int> &texture_sources) {
    for_each_object(root, "materials", "material", [&](const json &m, const std::string &where, size_t) {
        const json *pbr = find_member(m, "pbrMetallicRoughness");
        const json *extensions = find_member(m, "extensions");
        const json *transmission = extensions ? find_member(*extensions, "KHR_materials_transmission") : nullptr;
        const json *specular = extensions ? find_member(*extensions, "KHR_materials_specular") : nullptr;
        const json *sheen = extensions ? find_member(*extensions, "KHR_materials_sheen") : nullptr;
        const json *clearcoat = extensions ? find_member(*extensions, "KHR_materials_clearcoat") : nullptr;
        struct { const json *parent; const char *key; int kind; } infos[] = {
            {pbr, "baseColorTexture", kBaseColor}, {pbr, "metallicRoughnessTexture", kMetallicRoughness},
            {&m, "normalTexture", kNormal}, {&m, "occlusionTexture", -1}, {&m, "emissiveTexture", kEmissive},
            {transmission, "transmissionTexture", kTransmission},
            {specular, "specularTexture", kSpecular}, {specular, "specularColorTexture", kSpecularColor},
            {sheen, "sheenColorTexture", kSheenColor}, {sheen, "sheenRoughnessTexture", kSheenRoughness},
            {clearcoat, "clearcoatTexture", kClearcoat}, {clearcoat, "clearcoatRoughnessTexture", kClearcoatRoughness},
            {clearcoat, "clearcoatNormalTexture", kClearcoatNormal}};
        references_.emplace_back();
        for (const auto &info : infos) {
            const json *ti = info.parent ? find_member(*info.parent, info.key) : nullptr;
            if (!ti) continue;
            std::string sub = where + " " + info.key;
            if (!ti->is_object()) fail(std::string(info.key) + " is not an object (" + where + ")");
            int texture = required_index(*ti, "index", count_textures_, "texture", sub);
            uint64_t texcoord = unsigned_member(*ti, "texCoord", false, 0, INT_MAX, sub);
            if (info.kind < 0) continue;
            TextureReference r;
            r.texture = texture;
            r.texcoord = texcoord;
            read_texture_transform(*ti, sub, &r);
            references_.back()[info.kind] = r;
            if (texture_sources[texture] >= 0) hooks_.image_wanted[texture_sources[texture]] = 1;
        }
    });
}

// Each mesh's primitives: their attributes, indices, material and mode.
void Loader::preflight_meshes(const json &root) {
    for_each_object(root, "meshes", "mesh", [&](const json &mesh, const std::string &where, size_t) {
        const json *prims = find_member(mesh, "primitives");
        if (!prims || !prims->is_array()) fail("missing primitives array (" + where + ")");
        for (size_t p = 0; p < prims->size(); p++) {
            std::string sub = where + " primitive " + str(p);
            const json &prim = (*prims)[p];
            const json *attributes = find_member(prim, "attributes");
            if (!attributes || !attributes->is_object()) fail("missing attributes object (" + sub + ")");
            for (auto it = attributes->begin(); it != attributes->end(); ++it)
                index_value(it.value(), count_accessors_, "accessor", sub + " " + printable(it.key(), 32));
            optional_index(prim, "indices", count_accessors_, "accessor", sub + " indices");
            optional_index(prim, "material", count_materials_, "material", sub);
            uint64_t mode = unsigned_member(prim, "mode", false, 4, UINT32_MAX, sub);
            if (mode > 6) fail("unknown primitive mode " + str(mode) + " (" + sub + ")");
        }
        primitives_per_mesh_.push_back(prims->size());
    });
}

// The nodes' references (children, mesh, camera, skin, light, GPU instancing attributes), the
// scenes' nodes and the default scene.
void Loader::preflight_nodes_and_scenes(const json &root) {
    for_each_object(root, "nodes", "node", [&](const json &node, const std::string &where, size_t) {
        for (const json &child : optional_array(node, "children", where))
            index_value(child, count_nodes_, "node", where + " children");
        optional_index(node, "mesh", count_meshes_, "mesh", where);
        optional_index(node, "camera", count_cameras_, "camera", where);
        optional_index(node, "skin", count_skins_, "skin", where);
        const json *ext = find_member(node, "extensions");
        const json *light = ext ? find_member(*ext, "KHR_lights_punctual") : nullptr;
        if (light) required_index(*light, "light", count_lights_, "light", where + " KHR_lights_punctual");
        const json *gpu = ext ? find_member(*ext, "EXT_mesh_gpu_instancing") : nullptr;
        if (gpu) {
            std::string sub = where + " EXT_mesh_gpu_instancing";
            const json *attributes = gpu->is_object() ? find_member(*gpu, "attributes") : nullptr;
            if (!attributes || !attributes->is_object()) fail("missing attributes object (" + sub + ")");
            for (const char *name : {"TRANSLATION", "ROTATION", "SCALE"})
                optional_index(*attributes, name, count_accessors_, "accessor", sub + " " + name);
        }
    });

    for_each_object(root, "scenes", "scene", [&](const json &scene, const std::string &where, size_t) {
        for (const json &n : optional_array(scene, "nodes", where)) index_value(n, count_nodes_, "node", where);
    });
    optional_index(root, "scene", count_scenes_, "scene", "default scene");
}

// EXT_meshopt_compression on bufferViews and KHR_draco_mesh_compression on primitives: their
// members and ranges, so decode_compressed can trust them.
void Loader::preflight_compressed(const json &root) {
    for_each_object(root, "bufferViews", "bufferView", [&](const json &bv, const std::string &view_where, size_t i) {
        const json *extensions = find_member(bv, "extensions");
        const json *ext = extensions ? find_member(*extensions, "EXT_meshopt_compression") : nullptr;
        if (!ext) return;
        std::string where = view_where + " EXT_meshopt_compression";
        if (!ext->is_object()) fail("EXT_meshopt_compression is not an object (" + view_where + ")");
        MeshoptView m;
        m.view = static_cast<int>(i);
        m.buffer = required_index(*ext, "buffer", count_buffers_, "buffer", where);
        m.offset = unsigned_member(*ext, "byteOffset", false, 0, UINT64_MAX, where);
        m.length = unsigned_member(*ext, "byteLength", true, 0, UINT64_MAX, where);
        m.stride = unsigned_member(*ext, "byteStride", true, 0, 256, where);
        m.count = unsigned_member(*ext, "count", true, 0, UINT32_MAX, where);
        uint64_t available = buffer_lengths_[m.buffer];
        if (m.offset > available || m.length > available - m.offset)
            fail("compressed range (offset " + str(m.offset) + " + length " + str(m.length) + ") exceeds buffer " +
                 str(m.buffer) + " (" + str(available) + " bytes) (" + where + ")");
        if (fallback_buffers_[m.buffer])
            fail("buffer " + str(m.buffer) + " holds the compressed bytes but is a fallback buffer without data (" + where + ")");
        const json *mode = find_member(*ext, "mode");
        if (!mode || !mode->is_string()) fail("missing mode string (" + where + ")");
        m.mode = pm_meshopt_mode(mode->get_ref<const std::string &>().c_str());
        if (m.mode == PM_MESHOPT_MODE_UNKNOWN) fail("unknown mode " + printable(mode->get<std::string>()) + " (" + where + ")");
        const json *filter = find_member(*ext, "filter");
        if (filter && !filter->is_string()) fail("filter is " + describe(*filter) + ", not a string (" + where + ")");
        m.filter = filter ? pm_meshopt_filter(filter->get_ref<const std::string &>().c_str()) : PM_MESHOPT_FILTER_NONE;
        if (m.filter == PM_MESHOPT_FILTER_UNKNOWN) fail("unknown filter " + printable(filter->get<std::string>()) + " (" + where + ")");
        meshopt_views_.push_back(m);
    });
    for_each_object(root, "meshes", "mesh", [&](const json &mesh, const std::string &mesh_where, size_t mi) {
        const json &prims = *find_member(mesh, "primitives");
        for (size_t p = 0; p < prims.size(); p++) {
            const json &prim = prims[p];
            const json *extensions = find_member(prim, "extensions");
            const json *ext = extensions ? find_member(*extensions, "KHR_draco_mesh_compression") : nullptr;
            if (!ext) continue;
            std::string where = mesh_where + " primitive " + str(p) + " KHR_draco_mesh_compression";
            if (!ext->is_object()) fail("KHR_draco_mesh_compression is not an object (" + where + ")");
            DracoPrimitive d;
            d.mesh = static_cast<int>(mi);
            d.primitive = static_cast<int>(p);
            d.view = required_index(*ext, "bufferView", count_views_, "bufferView", where);
            const json *ids = find_member(*ext, "attributes");
            if (!ids || !ids->is_object()) fail("missing attributes object (" + where + ")");
            const json &attributes = *find_member(prim, "attributes");
            for (auto it = ids->begin(); it != ids->end(); ++it) {
                std::string name = printable(it.key(), 32);
                const json *accessor = find_member(attributes, it.key().c_str());
                if (!accessor) fail("attribute " + name + " is not among the primitive's attributes (" + where + ")");
                uint64_t id = unsigned_member(*ids, it.key().c_str(), true, 0, UINT32_MAX, where);
                d.accessor_ids.emplace_back(accessor->get<int>(), static_cast<uint32_t>(id));
            }
            draco_primitives_.push_back(d);
        }
    });
}

// Every texture reference (an object named ...Texture with an "index") anywhere inside an
// extension object, such as KHR_materials_volume's thicknessTexture: its index must exist.
void check_nested_texture_indices(const json &value, size_t textures, const std::string &where, int depth = 0) {
    if (depth > kMaxJsonDepth || !value.is_object()) return;
    for (auto it = value.begin(); it != value.end(); ++it) {
        const std::string &key = it.key();
        bool texture_info = key.size() > 7 && key.compare(key.size() - 7, 7, "Texture") == 0 && it->is_object();
        if (texture_info)
            required_index(*it, "index", textures, "texture", where + " " + printable(key, 40));
        else if (it->is_object())
            check_nested_texture_indices(*it, textures, where + " " + printable(key, 40), depth + 1);
    }
}

// Indices pmview does not use but glTF still requires to resolve: morph targets, skins,
// animations, material variants, texture sources given by extensions, extension textures.
void Loader::preflight_other_indices(const json &root) {
    for_each_object(root, "meshes", "mesh", [&](const json &mesh, const std::string &where, size_t) {
        const json &prims = *find_member(mesh, "primitives");  // the mesh pass checked it is an array
        for (size_t p = 0; p < prims.size(); p++) {
            std::string sub = where + " primitive " + str(p);
            const json &targets = optional_array(prims[p], "targets", sub);
            for (size_t t = 0; t < targets.size(); t++) {
                std::string target = sub + " morph target " + str(t);
                if (!targets[t].is_object()) fail("morph target is not a JSON object (" + target + ")");
                for (auto it = targets[t].begin(); it != targets[t].end(); ++it)
                    index_value(it.value(), count_accessors_, "accessor", target + " " + printable(it.key(), 32));
            }
            const json *ext = typed_object(prims[p], "extensions", sub);
            const json *variants = ext ? typed_object(*ext, "KHR_materials_variants", sub) : nullptr;
            if (!variants) continue;
            const json &mappings = optional_array(*variants, "mappings", sub + " KHR_materials_variants");
            for (size_t k = 0; k < mappings.size(); k++)
                required_index(mappings[k], "material", count_materials_, "material",
                               sub + " KHR_materials_variants mapping " + str(k));
        }
    });
    for_each_object(root, "skins", "skin", [&](const json &skin, const std::string &where, size_t) {
        optional_index(skin, "inverseBindMatrices", count_accessors_, "accessor", where + " inverseBindMatrices");
        optional_index(skin, "skeleton", count_nodes_, "node", where + " skeleton");
        const json *joints = find_member(skin, "joints");
        if (!joints || !joints->is_array() || joints->empty()) fail("joints must be a non-empty array (" + where + ")");
        for (size_t j = 0; j < joints->size(); j++)
            index_value((*joints)[j], count_nodes_, "node", where + " joint " + str(j));
    });
    for_each_object(root, "animations", "animation", [&](const json &animation, const std::string &where, size_t) {
        const json &samplers = optional_array(animation, "samplers", where);
        for (size_t k = 0; k < samplers.size(); k++) {
            std::string sub = where + " sampler " + str(k);
            required_index(samplers[k], "input", count_accessors_, "accessor", sub + " input");
            required_index(samplers[k], "output", count_accessors_, "accessor", sub + " output");
            typed_string(samplers[k], "interpolation", false, {"LINEAR", "STEP", "CUBICSPLINE"}, sub);
        }
        const json &channels = optional_array(animation, "channels", where);
        for (size_t k = 0; k < channels.size(); k++) {
            std::string sub = where + " channel " + str(k);
            required_index(channels[k], "sampler", samplers.size(), "animation sampler", sub);
            const json *target = typed_object(channels[k], "target", sub);
            if (!target) fail("missing target (" + sub + ")");
            optional_index(*target, "node", count_nodes_, "node", sub + " target");
            typed_string(*target, "path", true, {"translation", "rotation", "scale", "weights"}, sub + " target");
        }
    });
    for_each_object(root, "textures", "texture", [&](const json &t, const std::string &where, size_t) {
        const json *ext = typed_object(t, "extensions", where);
        if (!ext) return;
        for (auto it = ext->begin(); it != ext->end(); ++it)
            if (it->is_object()) optional_index(*it, "source", count_images_, "image", where + " " + printable(it.key(), 40));
    });
    for_each_object(root, "materials", "material", [&](const json &m, const std::string &where, size_t) {
        const json *ext = typed_object(m, "extensions", where);
        if (ext) check_nested_texture_indices(*ext, count_textures_, where);
    });
}

// A material's members and those of its extensions, each of the type and length glTF's schema gives.
void check_material_member_types(const json &m, const std::string &where) {
    typed_string(m, "name", false, {}, where);
    if (const json *pbr = typed_object(m, "pbrMetallicRoughness", where)) {
        std::string sub = where + " pbrMetallicRoughness";
        typed_numbers(*pbr, "baseColorFactor", 4, sub);
        typed_number(*pbr, "metallicFactor", false, sub);
        typed_number(*pbr, "roughnessFactor", false, sub);
    }
    if (const json *normal = typed_object(m, "normalTexture", where))
        typed_number(*normal, "scale", false, where + " normalTexture");
    if (const json *occlusion = typed_object(m, "occlusionTexture", where))
        typed_number(*occlusion, "strength", false, where + " occlusionTexture");
    typed_numbers(m, "emissiveFactor", 3, where);
    typed_string(m, "alphaMode", false, {"OPAQUE", "MASK", "BLEND"}, where);
    typed_number(m, "alphaCutoff", false, where);
    typed_bool(m, "doubleSided", where);
    const json *ext = typed_object(m, "extensions", where);
    if (!ext) return;
    struct { const char *extension; const char *members[3]; } numbers[] = {
        {"KHR_materials_transmission", {"transmissionFactor"}},
        {"KHR_materials_ior", {"ior"}},
        {"KHR_materials_emissive_strength", {"emissiveStrength"}},
        {"KHR_materials_volume", {"thicknessFactor", "attenuationDistance"}},
        {"KHR_materials_clearcoat", {"clearcoatFactor", "clearcoatRoughnessFactor"}},
        {"KHR_materials_sheen", {"sheenRoughnessFactor"}},
        {"KHR_materials_specular", {"specularFactor"}}};
    for (const auto &n : numbers) {
        const json *e = typed_object(*ext, n.extension, where);
        if (!e) continue;
        for (const char *member : n.members)
            if (member) typed_number(*e, member, false, where + " " + n.extension);
        if (!strcmp(n.extension, "KHR_materials_volume"))
            typed_numbers(*e, "attenuationColor", 3, where + " " + n.extension);
        if (!strcmp(n.extension, "KHR_materials_sheen")) typed_numbers(*e, "sheenColorFactor", 3, where + " " + n.extension);
        if (!strcmp(n.extension, "KHR_materials_specular"))
            typed_numbers(*e, "specularColorFactor", 3, where + " " + n.extension);
    }
}

// Material, light, camera and node members of the wrong type or length (see typed_number).
void Loader::preflight_typed_members(const json &root) {
    for_each_object(root, "materials", "material",
                    [&](const json &m, const std::string &where, size_t) { check_material_member_types(m, where); });

    const json *root_ext = find_member(root, "extensions");
    const json *lights_ext = root_ext ? find_member(*root_ext, "KHR_lights_punctual") : nullptr;
    if (lights_ext && !lights_ext->is_object()) fail("KHR_lights_punctual must be an object (top level extensions)");
    if (lights_ext)
        for_each_object(*lights_ext, "lights", "light", [&](const json &l, const std::string &where, size_t) {
            typed_string(l, "name", false, {}, where);
            typed_string(l, "type", true, {"directional", "point", "spot"}, where);
            typed_numbers(l, "color", 3, where);
            typed_number(l, "intensity", false, where);
            typed_number(l, "range", false, where);
            const json *spot = typed_object(l, "spot", where);
            if (spot) {
                typed_number(*spot, "innerConeAngle", false, where + " spot");
                typed_number(*spot, "outerConeAngle", false, where + " spot");
            }
        });

    for_each_object(root, "cameras", "camera", [&](const json &c, const std::string &where, size_t) {
        typed_string(c, "type", true, {"perspective", "orthographic"}, where);
        bool perspective = c.at("type") == "perspective";
        const char *kind = perspective ? "perspective" : "orthographic";
        const json *params = typed_object(c, kind, where);
        if (!params) fail(std::string("missing ") + kind + " object (" + where + ")");
        std::string sub = where + " " + kind;
        if (perspective) {
            typed_number(*params, "yfov", true, sub);
            typed_number(*params, "znear", true, sub);
            typed_number(*params, "aspectRatio", false, sub);
            typed_number(*params, "zfar", false, sub);
        } else {
            for (const char *member : {"xmag", "ymag", "znear", "zfar"}) typed_number(*params, member, true, sub);
        }
    });

    for_each_object(root, "nodes", "node", [&](const json &node, const std::string &where, size_t) {
        typed_string(node, "name", false, {}, where);
        typed_numbers(node, "matrix", 16, where);
        typed_numbers(node, "translation", 3, where);
        typed_numbers(node, "rotation", 4, where);
        typed_numbers(node, "scale", 3, where);
        typed_numbers(node, "weights", 0, where);
    });
    for_each_object(root, "meshes", "mesh", [&](const json &mesh, const std::string &where, size_t) {
        typed_numbers(mesh, "weights", 0, where);
    });
    for_each_object(root, "accessors", "accessor", [&](const json &a, const std::string &where, size_t) {
        typed_bool(a, "normalized", where);
        typed_numbers(a, "min", 0, where);
        typed_numbers(a, "max", 0, where);
    });
}

// Buffer sizes and URIs, before tinygltf opens anything.
void Loader::preflight_buffers(const json &root) {
    for_each_object(root, "buffers", "buffer", [&](const json &b, const std::string &where, size_t i) {
        uint64_t length = unsigned_member(b, "byteLength", true, 0, UINT64_MAX, where);
        const json *extensions = find_member(b, "extensions");
        const json *meshopt = extensions ? find_member(*extensions, "EXT_meshopt_compression") : nullptr;
        const json *fallback = meshopt && meshopt->is_object() ? find_member(*meshopt, "fallback") : nullptr;
        // EXT_meshopt_compression: a buffer only compressed bufferViews point into needs no bytes
        fallback_buffers_.push_back(fallback && fallback->is_boolean() && fallback->get<bool>() && !find_member(b, "uri"));
        if (fallback_buffers_.back()) {
        } else if (find_member(b, "uri")) {
            preflight_uri_target(b, where, true, length);
        } else if (!binary_) {
            fail("buffer " + str(i) + " has no uri (only a .glb embeds its buffer)");
        } else if (i != 0) {
            fail("buffer " + str(i) + " has no uri: only buffer 0 can be the GLB's BIN chunk");
        } else if (!has_bin_) {
            fail("buffer " + str(i) + " has no uri and the GLB has no BIN chunk");
        } else if (length > bin_size_) {
            fail("byteLength " + str(length) + " exceeds the GLB BIN chunk (" + str(bin_size_) + " bytes) (" + where + ")");
        } else if (bin_size_ - length > 3) {
            fail("byteLength " + str(length) + " but the GLB BIN chunk has " + str(bin_size_) +
                 " bytes (at most 3 bytes of padding) (" + where + ")");
        }
        buffer_lengths_.push_back(length);
    });
}

// A buffer's or image's uri: a well-formed data: URI (of the declared size for buffers) or a safe
// relative path (an existing file of the declared size for buffers; tinygltf reports missing images).
void Loader::preflight_uri_target(const json &object, const std::string &where, bool is_buffer, uint64_t byte_length) {
    const json *uri_value = find_member(object, "uri");
    if (!uri_value) return;
    if (!uri_value->is_string()) fail("uri is " + describe(*uri_value) + ", not a string (" + where + ")");
    const std::string &uri = uri_value->get_ref<const std::string &>();
    if (starts_with_data_scheme(uri)) {
        int64_t size = data_uri_size(uri);
        if (size < 0) fail("malformed data: URI (" + where + ")");
        if (is_buffer && static_cast<uint64_t>(size) != byte_length)
            fail("byteLength " + str(byte_length) + " but the data: URI holds " + str(static_cast<uint64_t>(size)) +
                 " bytes: buffer size mismatch (" + where + ")");
        return;
    }
    std::string relative = safe_relative_path(uri, folder_, hooks_.folder, where);
    if (!is_buffer) return;
    if (hooks_.no_files)
        fail("buffer " + printable(uri) + " is an external file, unavailable when loading from memory (" + where + ")");
    struct stat st;
    std::string file = join_path(folder_, relative);
    if (stat(file.c_str(), &st) != 0)
        fail("cannot open buffer " + printable(uri) + ": " + strerror(errno) + " (" + where + ")");
    if (!S_ISREG(st.st_mode)) fail("buffer " + printable(uri) + " is not a regular file (" + where + ")");
    if (static_cast<uint64_t>(st.st_size) != byte_length)
        fail("buffer file " + printable(uri) + " has " + str(static_cast<uint64_t>(st.st_size)) +
             " bytes but byteLength is " + str(byte_length) + " (" + where + ")");
}

// ---------------- model building: tinygltf's Model from the checked document, geometry decompressed

// Calls parse(element) for each element of the array parent[key], in order, until one returns
// false. The preflight made every such array one of objects; a document it did not check is refused.
template <class F>
bool each_object(const json &parent, const char *key, F parse) {
    const json *items = find_member(parent, key);
    if (!items) return true;
    if (!items->is_array()) fail(std::string(key) + " must be an array (top level)");
    for (const json &o : *items) {
        if (!o.is_object()) fail(std::string(key) + " holds " + describe(o) + ", not a JSON object");
        if (!parse(o)) return false;
    }
    return true;
}

// Each element of parent[key] through tinygltf's parser for its kind, appended to *out.
template <class T, class F>
bool parse_objects(const json &parent, const char *key, std::vector<T> *out, F parse) {
    return each_object(parent, key, [&](const json &o) {
        T item;
        if (!parse(&item, o)) return false;
        out->push_back(std::move(item));
        return true;
    });
}

// The Model as TinyGLTF::LoadFromString builds it after its own parse, section by section in the
// same order with the same per-object parsers (this unit holds tinygltf's implementation), but from
// the document the preflight checked. LoadFromString's refusals before its sections (text under 4
// bytes, a root that is not an object, no asset.version) and LoadBinaryFromMemory's container
// checks are the preflight's and split_container's already, each stricter. Buffers are read through
// the guarded file-system hooks and images decoded through load_wanted_image.
void Loader::build_model(const json &root) {
    ModelParse parse;
    parse.fs = {guarded_file_exists, unexpanded_path, guarded_read_file, refuse_write, &hooks_};
    parse.image_loader = load_wanted_image;
    hooks_.images = &model_.images;
    bool ok = parse_model_geometry(root, parse) && mark_buffer_view_targets(parse) &&
              parse_model_nodes_and_materials(root, parse) && parse_model_images(root, parse);
    if (ok) decode_pending_images(&hooks_);
    ok = ok && parse_model_remaining(root, parse);
    if (!hooks_.error.empty()) fail(hooks_.error);
    if (!ok) fail("tinygltf: " + (parse.error.empty() ? std::string("load failed") : one_line(parse.error)));
    for (const std::string &w : hooks_.warnings) warn(w);
    if (!parse.warning.empty()) warn("tinygltf: " + one_line(parse.warning));
    if (!parse.error.empty()) warn("tinygltf: " + one_line(parse.error));
    check_model_counts();
    decode_compressed();
    // every accessor's byte ranges, used by the default scene or not, as for every other index
    for (size_t a = 0; a < model_.accessors.size(); a++) accessor_layout(model_, static_cast<int>(a));
}

// The asset, the extension lists, buffers, bufferViews, accessors and meshes.
bool Loader::parse_model_geometry(const json &root, ModelParse &parse) {
    Model &model = model_;
    std::string *err = &parse.error;
    const bool keep_json = ModelParse::kKeepJson;
    if (const json *asset = find_member(root, "asset"))
        if (asset->is_object()) tinygltf::ParseAsset(&model.asset, err, *asset, keep_json);
    for (const char *key : {"extensionsUsed", "extensionsRequired"}) {
        std::vector<std::string> &names = !strcmp(key, "extensionsUsed") ? model.extensionsUsed : model.extensionsRequired;
        const json *list = find_member(root, key);
        if (list && list->is_array())
            for (const json &e : *list) names.push_back(e.is_string() ? e.get<std::string>() : std::string());
    }
    const unsigned char *bin = binary_ ? bin_data_ : nullptr;
    size_t bin_size = binary_ && bin_data_ ? bin_size_ : 0;
    return parse_objects(root, "buffers", &model.buffers,
                         [&](tinygltf::Buffer *b, const json &o) {
                             if (fallback_buffers_[model.buffers.size()]) return true;  // its bufferViews are decoded
                             return tinygltf::ParseBuffer(b, err, o, keep_json, &parse.fs, folder_, binary_, bin, bin_size);
                         }) &&
           parse_objects(root, "bufferViews", &model.bufferViews, [&](tinygltf::BufferView *v, const json &o) {
               return tinygltf::ParseBufferView(v, err, o, keep_json);
           }) &&
           parse_objects(root, "accessors", &model.accessors, [&](tinygltf::Accessor *a, const json &o) {
               return tinygltf::ParseAccessor(a, err, o, keep_json);
           }) &&
           parse_objects(root, "meshes", &model.meshes, [&](tinygltf::Mesh *mesh, const json &o) {
               return tinygltf::ParseMesh(mesh, &model, err, o, keep_json);
           });
}

// bufferView targets from their use, as LoadFromString sets them; it refuses an index accessor
// without a bufferView.
bool Loader::mark_buffer_view_targets(ModelParse &parse) {
    Model &model = model_;
    auto mark_target = [&](int accessor, int target) {
        if (accessor < 0 || static_cast<size_t>(accessor) >= model.accessors.size()) return;
        int view = model.accessors[accessor].bufferView;
        if (view >= 0 && static_cast<size_t>(view) < model.bufferViews.size()) model.bufferViews[view].target = target;
    };
    for (tinygltf::Mesh &mesh : model.meshes)
        for (tinygltf::Primitive &p : mesh.primitives) {
            if (p.indices > -1) {
                if (static_cast<size_t>(p.indices) >= model.accessors.size()) {
                    parse.error += "primitive indices accessor out of bounds";
                    return false;
                }
                int view = model.accessors[p.indices].bufferView;
                // a Draco primitive's indices have no bufferView until decode_compressed fills them
                bool draco = view < 0 && p.extensions.count("KHR_draco_mesh_compression");
                if (!draco && (view < 0 || static_cast<size_t>(view) >= model.bufferViews.size())) {
                    parse.error += "accessor[" + std::to_string(p.indices) + "] invalid bufferView";
                    return false;
                }
                if (!draco) model.bufferViews[view].target = TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER;
            }
            for (const auto &a : p.attributes) mark_target(a.second, TINYGLTF_TARGET_ARRAY_BUFFER);
            for (const auto &t : p.targets)
                for (const auto &a : t) mark_target(a.second, TINYGLTF_TARGET_ARRAY_BUFFER);
        }
    return true;
}

// Nodes, scenes, the default scene and materials.
bool Loader::parse_model_nodes_and_materials(const json &root, ModelParse &parse) {
    Model &model = model_;
    std::string *err = &parse.error;
    const bool keep_json = ModelParse::kKeepJson;
    if (!parse_objects(root, "nodes", &model.nodes, [&](tinygltf::Node *n, const json &o) {
            return tinygltf::ParseNode(n, err, o, keep_json);
        }))
        return false;
    parse_objects(root, "scenes", &model.scenes, [&](tinygltf::Scene *s, const json &o) {
        tinygltf::ParseIntegerArrayProperty(&s->nodes, err, o, "nodes", false);
        tinygltf::ParseStringProperty(&s->name, err, o, "name", false);
        tinygltf::ParseExtensionsProperty(&s->extensions, err, o);
        tinygltf::ParseExtrasProperty(&s->extras, o);
        return true;
    });
    if (const json *scene = find_member(root, "scene")) tinygltf::GetInt(*scene, model.defaultScene);
    return parse_objects(root, "materials", &model.materials, [&](tinygltf::Material *material, const json &o) {
        tinygltf::ParseStringProperty(&material->name, err, o, "name", false);
        return tinygltf::ParseMaterial(material, err, o, keep_json);
    });
}

// Images, each decoded through load_wanted_image from its file, data: URI or bufferView.
bool Loader::parse_model_images(const json &root, ModelParse &parse) {
    Model &model = model_;
    std::string *err = &parse.error;
    uint32_t sourceless_images = 0;
    int first_sourceless = -1;
    if (!parse_objects(root, "images", &model.images, [&](tinygltf::Image *image, const json &o) {
            int index = static_cast<int>(model.images.size());
            // gltfpack writes an image with neither for every image it could not read: left
            // out (its textures with it) as an unreadable file is, not the whole model refused
            if (!find_member(o, "uri") && !find_member(o, "bufferView")) {
                if (sourceless_images++ == 0) first_sourceless = index;
                tinygltf::ParseStringProperty(&image->name, err, o, "name", false);
                return true;
            }
            if (!tinygltf::ParseImage(image, index, err, &parse.warning, o, ModelParse::kKeepJson, folder_, &parse.fs,
                                      &parse.image_loader, &hooks_))
                return false;
            if (image->bufferView < 0) return true;
            // the preflight checked the view's range inside its buffer, whose bytes ParseBuffer read in full
            const tinygltf::BufferView &view = model.bufferViews.at(image->bufferView);
            const tinygltf::Buffer &buffer = model.buffers.at(view.buffer);
            if (view.byteOffset > buffer.data.size() || view.byteLength > buffer.data.size() - view.byteOffset)
                fail("image " + str(index) + ": its bufferView exceeds the bytes read");
            return parse.image_loader(image, index, err, &parse.warning, image->width, image->height,
                                      buffer.data.data() + view.byteOffset, static_cast<int>(view.byteLength), &hooks_);
        }))
        return false;
    if (sourceless_images)
        warn("ignored: " + str(sourceless_images) + " image(s) with neither uri nor bufferView (no data; their textures are " +
             "left out), first image " + str(first_sourceless));
    return true;
}

// Textures, animations, skins, samplers, cameras, the root's extensions, lights and extras.
bool Loader::parse_model_remaining(const json &root, ModelParse &parse) {
    Model &model = model_;
    std::string *err = &parse.error;
    const bool keep_json = ModelParse::kKeepJson;
    if (!parse_objects(root, "textures", &model.textures, [&](tinygltf::Texture *t, const json &o) {
            return tinygltf::ParseTexture(t, err, o, keep_json, folder_);
        }) ||
        !parse_objects(root, "animations", &model.animations, [&](tinygltf::Animation *a, const json &o) {
            return tinygltf::ParseAnimation(a, err, o, keep_json);
        }) ||
        !parse_objects(root, "skins", &model.skins, [&](tinygltf::Skin *s, const json &o) {
            return tinygltf::ParseSkin(s, err, o, keep_json);
        }) ||
        !parse_objects(root, "samplers", &model.samplers, [&](tinygltf::Sampler *s, const json &o) {
            return tinygltf::ParseSampler(s, err, o, keep_json);
        }) ||
        !parse_objects(root, "cameras", &model.cameras, [&](tinygltf::Camera *c, const json &o) {
            return tinygltf::ParseCamera(c, err, o, keep_json);
        }))
        return false;
    tinygltf::ParseExtensionsProperty(&model.extensions, err, root);
    const json *extensions = find_member(root, "extensions");
    const json *punctual = extensions ? find_member(*extensions, "KHR_lights_punctual") : nullptr;
    if (punctual && punctual->is_object() &&
        !parse_objects(*punctual, "lights", &model.lights, [&](tinygltf::Light *l, const json &o) {
            return tinygltf::ParseLight(l, err, o, keep_json);
        }))
        return false;
    tinygltf::ParseExtrasProperty(&model.extras, root);
    return true;
}

// The preflight checked indices against the raw JSON; tinygltf must have kept every element.
void Loader::check_model_counts() {
    struct { size_t raw, parsed; const char *what; } counts[] = {
        {count_scenes_, model_.scenes.size(), "scenes"}, {count_nodes_, model_.nodes.size(), "nodes"},
        {count_meshes_, model_.meshes.size(), "meshes"}, {count_accessors_, model_.accessors.size(), "accessors"},
        {count_views_, model_.bufferViews.size(), "bufferViews"}, {count_buffers_, model_.buffers.size(), "buffers"},
        {count_materials_, model_.materials.size(), "materials"}, {count_textures_, model_.textures.size(), "textures"},
        {count_images_, model_.images.size(), "images"}, {count_samplers_, model_.samplers.size(), "samplers"},
        {count_cameras_, model_.cameras.size(), "cameras"}, {count_lights_, model_.lights.size(), "lights"}};
    for (const auto &c : counts)
        if (c.raw != c.parsed)
            fail(std::string("tinygltf read ") + str(c.parsed) + " " + c.what + " where the JSON has " + str(c.raw));
    for (size_t m = 0; m < count_meshes_; m++)
        if (model_.meshes[m].primitives.size() != primitives_per_mesh_[m])
            fail("tinygltf dropped a primitive (mesh " + str(m) + ")");
    for (size_t b = 0; b < count_buffers_; b++)
        if (!fallback_buffers_[b] && model_.buffers[b].data.size() != buffer_lengths_[b])
            fail("loaded " + str(model_.buffers[b].data.size()) + " bytes, byteLength is " + str(buffer_lengths_[b]) +
                 ": buffer size mismatch (buffer " + str(b) + ")");
}

// Compressed geometry into plain buffers: each decoded bufferView or Draco attribute gets a buffer
// of its own and its bufferView (or accessor) is pointed at it, so the accessor checks that follow
// apply to the decoded bytes as to any others. Sizes are checked before anything is allocated:
// a meshopt view decodes to count x byteStride bytes, at most its bufferView's byteLength and
// PM_MESHOPT_MAX_RATIO times its stream; a Draco attribute to exactly its accessor's count, which
// must equal the points the stream decoded.
void Loader::decode_compressed() {
    decode_meshopt_views();
    for (size_t v = 0; v < model_.bufferViews.size(); v++) {
        int b = model_.bufferViews[v].buffer;
        if (static_cast<size_t>(b) < fallback_buffers_.size() && fallback_buffers_[b])
            fail("bufferView " + str(v) + " lies in buffer " + str(b) +
                 ", a fallback buffer without data, and is not EXT_meshopt_compression-compressed");
    }
    decode_draco_primitives();
}

// Decoded geometry's bytes admitted against --max-memory before they are allocated.
void Loader::admit_decoded(uint64_t bytes, const std::string &where) {
    const uint64_t mark = pm_memory_failure_mark();
    if (!pm_memory_admit(bytes, "decoded geometry"))
        fail("out of memory (" + std::string(pm_memory_failure_since_or(mark, "decoded geometry")) + ") (" + where + ")");
    decoded_.bytes += bytes;
}

// Decoded bytes as a buffer of their own; returns its index.
int Loader::own_buffer(std::vector<unsigned char> &&bytes) {
    model_.buffers.emplace_back();
    model_.buffers.back().data = std::move(bytes);
    return static_cast<int>(model_.buffers.size() - 1);
}

void Loader::decode_meshopt_views() {
    char message[512];
    for (const MeshoptView &m : meshopt_views_) {
        std::string where = "bufferView " + str(m.view) + " EXT_meshopt_compression";
        tinygltf::BufferView &bv = model_.bufferViews[m.view];
        if (bv.byteStride && bv.byteStride != m.stride)
            fail("byteStride " + str(m.stride) + " but the bufferView's is " + str(bv.byteStride) + " (" + where + ")");
        uint64_t decoded = m.count * m.stride;  // both checked to 32 bits
        if (decoded > bv.byteLength)
            fail("count " + str(m.count) + " x byteStride " + str(m.stride) + " exceeds the bufferView's byteLength " +
                 str(bv.byteLength) + " (" + where + ")");
        if (decoded / PM_MESHOPT_MAX_RATIO > m.length)
            fail("count " + str(m.count) + " x byteStride " + str(m.stride) + " is over " + str(PM_MESHOPT_MAX_RATIO) +
                 " times the " + str(m.length) + "-byte stream (" + where + ")");
        admit_decoded(decoded, where);
        std::vector<unsigned char> bytes(decoded);
        const unsigned char *src = model_.buffers[m.buffer].data.data() + m.offset;
        if (!pm_meshopt_decode(bytes.data(), m.count, m.stride, m.mode, m.filter, src, m.length, message, sizeof message))
            fail(std::string(message) + " (" + where + ")");
        bv.buffer = own_buffer(std::move(bytes));
        bv.byteOffset = 0;
        bv.byteLength = decoded;  // what the accessors may read: the decoded bytes
    }
}

// Per mesh, whether a node reached from the default scene places it (cycles are refused later by
// the traversal; here a node is visited once).
std::vector<char> Loader::meshes_in_default_scene() const {
    std::vector<char> placed_mesh(model_.meshes.size(), 0);
    if (model_.scenes.empty()) return placed_mesh;
    size_t scene = model_.defaultScene >= 0 ? static_cast<size_t>(model_.defaultScene) : 0;
    std::vector<char> seen(model_.nodes.size(), 0);
    std::vector<int> stack;
    if (scene < model_.scenes.size()) stack = model_.scenes[scene].nodes;
    while (!stack.empty()) {
        int n = stack.back();
        stack.pop_back();
        if (n < 0 || static_cast<size_t>(n) >= model_.nodes.size() || seen[n]) continue;
        seen[n] = 1;
        const tinygltf::Node &node = model_.nodes[n];
        if (node.mesh >= 0 && static_cast<size_t>(node.mesh) < placed_mesh.size()) placed_mesh[node.mesh] = 1;
        stack.insert(stack.end(), node.children.begin(), node.children.end());
    }
    return placed_mesh;
}

// Draco streams are decoded for the primitives of meshes the default scene's nodes place, each
// stream once however many primitives name it: a file of thousands of primitives naming one
// stream, or of unused meshes, took minutes decoding the same bytes again.
void Loader::decode_draco_primitives() {
    char message[512];
    std::vector<char> placed_mesh = meshes_in_default_scene();
    std::vector<size_t> order;  // the placed Draco primitives, grouped by stream
    for (size_t i = 0; i < draco_primitives_.size(); i++)
        if (placed_mesh[draco_primitives_[i].mesh]) order.push_back(i);
    std::stable_sort(order.begin(), order.end(),
                     [&](size_t a, size_t b) { return draco_primitives_[a].view < draco_primitives_[b].view; });
    std::unique_ptr<pm_draco_mesh, void (*)(pm_draco_mesh *)> mesh(nullptr, pm_draco_free);
    int decoded_view = -1;  // the stream `mesh` holds
    std::map<int, int> filled_from;  // accessor -> the bufferView of the Draco stream that filled it
    for (size_t index : order) {
        const DracoPrimitive &d = draco_primitives_[index];
        DracoFill fill = {d.view, "mesh " + str(d.mesh) + " primitive " + str(d.primitive) + " KHR_draco_mesh_compression",
                          &filled_from, message, sizeof message};
        const std::string &where = fill.where;
        tinygltf::Primitive &prim = model_.meshes[d.mesh].primitives[d.primitive];
        if (prim.mode != TINYGLTF_MODE_TRIANGLES) {
            if (prim.mode < TINYGLTF_MODE_TRIANGLES) continue;  // points and lines are skipped anyway
            fail("a Draco stream holds a triangle list, not mode " + str(prim.mode) + " (" + where + ")");
        }
        if (prim.indices < 0) fail("a Draco primitive needs an indices accessor (" + where + ")");
        if (d.view != decoded_view) {
            mesh.reset();  // the previous stream's decoded mesh goes before the next one is made
            const tinygltf::BufferView &bv = model_.bufferViews[d.view];
            mesh.reset(pm_draco_decode(model_.buffers[bv.buffer].data.data() + bv.byteOffset, bv.byteLength, message,
                                       sizeof message));
            if (!mesh) fail(std::string(message) + " (" + where + ", bufferView " + str(d.view) + ")");
            decoded_view = d.view;
        }
        uint64_t points = pm_draco_points(mesh.get()), triangles = pm_draco_triangles(mesh.get());
        if (triangles == 0) fail("the Draco stream holds no triangles (" + where + ")");
        for (const auto &ai : d.accessor_ids) {
            const tinygltf::Accessor &accessor = model_.accessors[ai.first];
            int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
            fill_from_draco(fill, ai.first, points, "points", [&](void *out) {
                return pm_draco_attribute(mesh.get(), ai.second, accessor.componentType, components, accessor.normalized,
                                          out, message, sizeof message);
            });
        }
        fill_from_draco(fill, prim.indices, 3 * triangles, "indices", [&](void *out) {
            return pm_draco_indices(mesh.get(), model_.accessors[prim.indices].componentType, out, message, sizeof message);
        });
    }
}

// Accessor a's `count` elements decoded from the Draco stream into a bufferView and buffer of their
// own; an accessor the same stream filled already is left as it is.
void Loader::fill_from_draco(const DracoFill &fill, int a, uint64_t count, const char *what,
                             const std::function<bool(void *)> &decode) {
    const std::string &where = fill.where;
    tinygltf::Accessor &accessor = model_.accessors[a];
    auto first = fill.filled_from->emplace(a, fill.view);
    if (!first.second) {
        if (first.first->second == fill.view) return;  // the same stream decoded for another primitive
        fail("accessor " + str(a) + " is filled by two Draco streams (bufferViews " + str(first.first->second) +
             " and " + str(fill.view) + ") (" + where + ")");
    }
    if (accessor.count != count)
        fail("accessor " + str(a) + " has count " + str(accessor.count) + " but the Draco stream decodes " +
             str(count) + " " + what + " (" + where + ")");
    int components = tinygltf::GetNumComponentsInType(static_cast<uint32_t>(accessor.type));
    size_t size = component_size(accessor.componentType);
    if (components <= 0 || size == 0)
        fail("unsupported accessor type (accessor " + str(a) + ", " + where + ")");
    admit_decoded(count * size * static_cast<size_t>(components), where);
    std::vector<unsigned char> bytes(count * size * static_cast<size_t>(components));
    if (!decode(bytes.data())) fail(std::string(fill.message) + " (accessor " + str(a) + ", " + where + ")");
    model_.bufferViews.emplace_back();
    tinygltf::BufferView &view = model_.bufferViews.back();
    view.byteLength = bytes.size();
    view.buffer = own_buffer(std::move(bytes));
    accessor.bufferView = static_cast<int>(model_.bufferViews.size() - 1);
    accessor.byteOffset = 0;
}

// ---------------- scene graph: the default scene's nodes, their lights and cameras

void Loader::traverse_default_scene() {
    if (model_.scenes.empty()) fail("nothing to render (the file has no scene)");
    int scene = model_.defaultScene >= 0 ? model_.defaultScene : 0;
    world_.assign(model_.nodes.size(), identity());
    // 0: not reached, 1: on the current path, 2: finished
    std::vector<char> state(model_.nodes.size(), 0);
    struct Step {
        int node, parent;
        bool leaving;
    };
    std::vector<Step> stack;
    const std::vector<int> &roots = model_.scenes[scene].nodes;
    for (auto it = roots.rbegin(); it != roots.rend(); ++it) stack.push_back({*it, -1, false});
    while (!stack.empty()) {
        Step step = stack.back();
        stack.pop_back();
        if (step.leaving) {
            state[step.node] = 2;
            continue;
        }
        if (state[step.node] == 1) fail("node hierarchy contains a cycle (node " + str(step.node) + ")");
        if (state[step.node] == 2)
            fail("node " + str(step.node) + " is reached twice (two parents, or listed twice in scene " + str(scene) + ")");
        state[step.node] = 1;
        const tinygltf::Node &node = model_.nodes[step.node];
        Mat4 local = local_matrix(node, step.node);
        world_[step.node] = step.parent >= 0 ? multiply(world_[step.parent], local) : local;
        if (!std::all_of(std::begin(world_[step.node].m), std::end(world_[step.node].m),
                         [](double x) { return std::isfinite(x); }))
            fail("world transform overflows (node " + str(step.node) + ")");
        // cameras and lights are placed once the scene's frame is known (choose_frame)
        if (node.camera >= 0) placed_.push_back({step.node, node.camera, false});
        auto light = node.extensions.find("KHR_lights_punctual");
        if (light != node.extensions.end() && light->second.Has("light"))
            placed_.push_back({step.node, light->second.Get("light").GetNumberAsInt(), true});
        auto gpu = node.extensions.find("EXT_mesh_gpu_instancing");
        if (node.mesh >= 0 && gpu != node.extensions.end()) read_instance_set(step.node, node, gpu->second);
        else if (node.mesh >= 0) instances_.push_back({step.node, node.mesh});
        stack.push_back({step.node, step.parent, true});
        for (auto it = node.children.rbegin(); it != node.children.rend(); ++it)
            stack.push_back({*it, step.node, false});
    }
    {
        // glTF: all nodes form disjoint strict trees, listed by the default scene or not: a node has
        // at most one parent, and every node descends from a parentless one (any other lies on a
        // cycle). After the default scene's walk, which names its own faults as it meets them.
        const size_t n = model_.nodes.size();
        std::vector<int> parent(n, -1);
        for (size_t i = 0; i < n; i++)
            for (int c : model_.nodes[i].children) {
                if (c < 0 || static_cast<size_t>(c) >= n) continue;  // dangling: named by the traversal below
                if (parent[c] >= 0)
                    fail("node " + str(c) + " is reached twice (two parents: nodes " + str(parent[c]) + " and " + str(i) + ")");
                parent[c] = static_cast<int>(i);
            }
        std::vector<char> descends(n, 0);
        std::vector<size_t> stack;
        for (size_t i = 0; i < n; i++)
            if (parent[i] < 0) stack.push_back(i);
        while (!stack.empty()) {
            size_t i = stack.back();
            stack.pop_back();
            descends[i] = 1;
            for (int c : model_.nodes[i].children)
                if (c >= 0 && static_cast<size_t>(c) < n && !descends[c]) stack.push_back(static_cast<size_t>(c));
        }
        for (size_t i = 0; i < n; i++)
            if (!descends[i]) fail("node hierarchy contains a cycle (node " + str(i) + ")");
    }
}

// A number the preflight found finite, brought into [lo, hi] with a warning naming it.
double Loader::checked(double value, double lo, double hi, const char *field, const std::string &object) {
    if (!std::isfinite(value)) fail(std::string("non-finite ") + field + " (" + object + ")");
    if (value < lo || value > hi) {
        double bound = value < lo ? lo : hi;
        note(object, field, num(value) + " clamped to " + num(bound));
        value = bound;
    }
    return value;
}

// An emission radiance or light intensity (in the scene's frame), hue (each in [0, 1]) times
// magnitude (>= 0, possibly infinite in double), as floats no larger than PM_MAX_EMISSION, which a
// float film can sum; a larger one keeps its hue, with a warning. made_of: how the value came from
// the file's numbers, for the warning.
vec3 Loader::emission_within_film(const double hue[3], double magnitude, const char *field, const std::string &made_of,
                                  const std::string &object) {
    double top = std::max(hue[0], std::max(hue[1], hue[2])), value[3];
    double largest = top > 0 ? top * magnitude : 0;
    for (int k = 0; k < 3; k++) value[k] = hue[k] > 0 ? hue[k] * magnitude : 0;
    if (largest > PM_MAX_EMISSION) {
        note(object, field, num(largest) + " (" + made_of + ") clamped to " + num(PM_MAX_EMISSION) +
                                " (PM_MAX_EMISSION: a float film could not sum more), hue kept");
        for (int k = 0; k < 3; k++) value[k] = hue[k] / top * PM_MAX_EMISSION;
    }
    return v3(static_cast<float>(value[0]), static_cast<float>(value[1]), static_cast<float>(value[2]));
}

double extension_number(const tinygltf::ExtensionMap &extensions, const char *extension, const char *key,
                        double fallback) {
    auto it = extensions.find(extension);
    if (it == extensions.end() || !it->second.IsObject() || !it->second.Has(key)) return fallback;
    const tinygltf::Value &v = it->second.Get(key);
    return v.IsNumber() ? v.GetNumberAsDouble() : fallback;
}

std::string Loader::material_label(size_t material) const {
    const std::string &name = model_.materials[material].name;
    return "material " + str(material) + (name.empty() ? "" : " (" + printable(name) + ")");
}

std::string Loader::mesh_label(int mesh, int primitive) const {
    const std::string &name = model_.meshes[mesh].name;
    return "mesh " + str(mesh) + (name.empty() ? "" : " (" + printable(name) + ")") + " primitive " + str(primitive);
}

void Loader::add_light(int index, const WorldTransform &world, int node) {
    const tinygltf::Light &l = model_.lights[index];
    std::string where = "light " + str(index);
    std::string label = "KHR_lights_punctual " + where + (l.name.empty() ? "" : " (" + printable(l.name) + ")");
    pm_light light;
    memset(&light, 0, sizeof light);
    if (l.type == "point") light.type = PM_LIGHT_POINT;
    else if (l.type == "spot") light.type = PM_LIGHT_SPOT;
    else if (l.type == "directional") light.type = PM_LIGHT_DIRECTIONAL;
    else return warn(label + " has unknown type " + printable(l.type) + "; skipped");
    if (!l.color.empty() && l.color.size() != 3)
        fail("color must have 3 numbers, got " + str(l.color.size()) + " (" + where + ")");
    if (light.type == PM_LIGHT_SPOT) {
        // KHR_lights_punctual: 0 <= innerConeAngle < outerConeAngle <= pi/2
        double outer = l.spot.outerConeAngle, inner = l.spot.innerConeAngle;
        if (!(outer > 0))
            return warn(label + " spot.outerConeAngle " + num(outer) +
                        " is not above 0: its cone is empty and it emits no light; dropped");
        outer = checked(outer, 0, M_PI / 2, "spot.outerConeAngle", label);
        inner = checked(inner, 0, M_PI / 2, "spot.innerConeAngle", label);
        if (inner >= outer) {
            note(label, "spot.innerConeAngle", num(inner) + " is not below outerConeAngle " + num(outer) +
                                                   ": set to it (a hard-edged cone)");
            inner = outer;
        }
        light.cos_inner = static_cast<float>(std::cos(inner));
        light.cos_outer = static_cast<float>(std::cos(outer));
    }
    double color[3] = {1, 1, 1};
    std::copy(l.color.begin(), l.color.end(), color);
    double intensity = checked(l.intensity, 0, INFINITY, "intensity", label);
    // In double until the scene's frame is applied: point and spot intensities scale by its
    // square (the same irradiance I / d^2 once distances are frame_scale_ times longer), so a
    // huge scene's huge intensity comes back to an ordinary one before any float or clamp.
    for (double &c : color) c = checked(c, 0, 1, "color", label);
    double framing = light.type == PM_LIGHT_DIRECTIONAL ? 1 : frame_scale_;
    double framed = intensity * framing * framing;  // one factor at a time: a range either would leave alone
    std::string made_of = "intensity " + num(intensity) + " x color" +
                          (framing != 1 ? " x unit_scale^2 " + num(framing * framing) : std::string());
    light.intensity = emission_within_film(color, framed, "intensity", made_of, label);
    double range = checked(l.range, 0, INFINITY, "range", label) * (light.type == PM_LIGHT_DIRECTIONAL ? 1 : frame_scale_);
    if (range > FLT_MAX) note(label, "range", num(range) + " (in the scene's frame) clamped to " + num(FLT_MAX));
    light.range = static_cast<float>(std::min<double>(range, FLT_MAX));  // unused by the renderer (docs/design.md: Lights and the environment)
    const double minus_z[3] = {0, 0, -1};
    light.position = world.origin();
    light.direction = world.unit(minus_z, false);
    if (!v3_is_finite(light.position) || (light.type != PM_LIGHT_POINT && v3_is_black(light.direction)))
        fail("degenerate transform for " + where + " (node " + str(node) + ")");
    lights_.push_back(light);
}

void Loader::add_camera(int index, const WorldTransform &world, int node) {
    const tinygltf::Camera &c = model_.cameras[index];
    std::string where = "camera " + str(index) + " on node " + str(node);
    bool orthographic = c.type == "orthographic";
    if (c.type != "perspective" && !orthographic)
        return warn(where + " is " + printable(c.type) + "; skipped (perspective and orthographic cameras are supported)");
    const tinygltf::PerspectiveCamera &p = c.perspective;
    const tinygltf::OrthographicCamera &o = c.orthographic;
    if (orthographic) {
        /* the specification forbids zero magnifications; a negative one would mirror the image */
        if (!(std::fabs(o.xmag) > 0) || !(std::fabs(o.ymag) > 0) || !std::isfinite(o.xmag) || !std::isfinite(o.ymag) ||
            std::fabs(o.ymag) > FLT_MAX || std::fabs(o.xmag) > FLT_MAX)
            return warn(where + " has an invalid xmag or ymag; skipped");
    } else if (!(p.yfov > 0 && p.yfov < M_PI) || !(p.znear > 0) || !std::isfinite(p.znear)) {
        return warn(where + " has an invalid yfov or znear; skipped");
    }
    const double minus_z[3] = {0, 0, -1}, plus_y[3] = {0, 1, 0};
    pm_camera cam;
    memset(&cam, 0, sizeof cam);
    cam.position = world.origin();
    cam.forward = world.unit(minus_z, false);
    vec3 up = world.unit(plus_y, false);
    up = v3_sub(up, v3_scale(cam.forward, v3_dot(up, cam.forward)));
    float up_length = v3_length(up);
    if (v3_is_black(cam.forward) || !(up_length > 1e-6f) || !v3_is_finite(cam.position))
        return warn(where + " has a degenerate transform; skipped");
    cam.up = v3_scale(up, 1.f / up_length);
    cam.right = v3_cross(cam.forward, cam.up);
    if (orthographic) {
        /* magnifications are in the camera node's units: the node's scale applies */
        const double plus_x[3] = {1, 0, 0};
        double scale_y = world.stretch(plus_y), scale_x = world.stretch(plus_x);
        cam.orthographic = true;
        cam.ymag = static_cast<float>(std::fabs(o.ymag) * scale_y);
        double xmag = std::fabs(o.xmag) * scale_x;
        cam.aspect = cam.ymag > 0.f && xmag / cam.ymag < FLT_MAX ? static_cast<float>(xmag / cam.ymag) : 0.f;
        cam.yfov = 0.f;
        cam.znear = 0.f;
        if (!(cam.ymag > 0.f) || !std::isfinite(cam.ymag)) return warn(where + " has an invalid ymag after its node's scale; skipped");
    } else {
        cam.yfov = static_cast<float>(p.yfov);
        cam.aspect = (p.aspectRatio > 0 && p.aspectRatio < FLT_MAX) ? static_cast<float>(p.aspectRatio) : 0.f;
        double znear = p.znear * frame_scale_;
        if (znear > FLT_MAX) note(where, "znear", num(znear) + " (in the scene's frame) clamped to " + num(FLT_MAX));
        cam.znear = static_cast<float>(std::min<double>(znear, FLT_MAX));
    }
    cameras_.push_back(cam);
}

// ---------------- materials: pm_materials from glTF's and its extensions', textures, variants

// KHR_materials_volume's attenuation coefficient: -ln(attenuationColor) / attenuationDistance per
// channel, for a material with a volume (thicknessFactor > 0; 0 is thin-walled) and a finite
// distance; 0 otherwise. thicknessFactor itself is for rasterizers: a ray tracer measures the
// distance inside the mesh. In double, per unit length of the file: choose_frame rescales it
// before it becomes a float. Returns whether the material has a volume (thicknessFactor > 0):
// without one, KHR_materials_transmission is a thin wall.
bool Loader::volume_attenuation(const tinygltf::ExtensionMap &extensions, const std::string &object, double sigma[3]) {
    std::fill(sigma, sigma + 3, 0.0);
    auto it = extensions.find("KHR_materials_volume");
    if (it == extensions.end() || !it->second.IsObject()) return false;
    double thickness = checked(extension_number(extensions, "KHR_materials_volume", "thicknessFactor", 0), 0, INFINITY,
                               "KHR_materials_volume thicknessFactor", object);
    double distance = extension_number(extensions, "KHR_materials_volume", "attenuationDistance", INFINITY);
    if (!(distance > 0)) fail("attenuationDistance must be positive (" + object + ")");
    double color[3] = {1, 1, 1};
    if (it->second.Has("attenuationColor")) {
        const tinygltf::Value &c = it->second.Get("attenuationColor");
        if (!c.IsArray() || c.ArrayLen() != 3) fail("attenuationColor must have 3 numbers (" + object + ")");
        for (int k = 0; k < 3; k++) {
            if (!c.Get(k).IsNumber()) fail("attenuationColor must have 3 numbers (" + object + ")");
            color[k] = checked(c.Get(k).GetNumberAsDouble(), 0, 1, "KHR_materials_volume attenuationColor", object);
        }
    }
    if (!(thickness > 0)) return false;
    if (std::isfinite(distance))
        for (int k = 0; k < 3; k++) sigma[k] = -std::log(std::max(color[k], 1e-30)) / distance;
    return true;
}

// A sampler's magFilter and minFilter into the texture (absent: LINEAR and trilinear by footprint).
void Loader::sampler_filters(const tinygltf::Sampler &s, int sampler, pm_texture *tex) {
    if (s.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST) tex->mag_nearest = true;
    else if (s.magFilter != -1 && s.magFilter != TINYGLTF_TEXTURE_FILTER_LINEAR)
        note("sampler " + str(sampler), "magFilter", std::to_string(s.magFilter) + " is not a glTF magnification filter; using LINEAR",
             false);
    static const struct { int gltf, pm; } mins[] = {
        {TINYGLTF_TEXTURE_FILTER_NEAREST, PM_MIN_NEAREST},
        {TINYGLTF_TEXTURE_FILTER_LINEAR, PM_MIN_LINEAR},
        {TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_NEAREST, PM_MIN_NEAREST_MIPMAP_NEAREST},
        {TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_NEAREST, PM_MIN_LINEAR_MIPMAP_NEAREST},
        {TINYGLTF_TEXTURE_FILTER_NEAREST_MIPMAP_LINEAR, PM_MIN_NEAREST_MIPMAP_LINEAR},
        {TINYGLTF_TEXTURE_FILTER_LINEAR_MIPMAP_LINEAR, PM_MIN_LINEAR_MIPMAP_LINEAR}};
    if (s.minFilter == -1) return;
    for (const auto &m : mins)
        if (m.gltf == s.minFilter) {
            tex->min_filter = m.pm;
            return;
        }
    note("sampler " + str(sampler), "minFilter", std::to_string(s.minFilter) + " is not a glTF minification filter; using LINEAR_MIPMAP_LINEAR",
         false);
}

int Loader::texture_for(int gltf_texture, const std::string &where) {
    auto known = texture_of_gltf_.find(gltf_texture);
    if (known != texture_of_gltf_.end()) return known->second;
    int &result = texture_of_gltf_[gltf_texture];
    result = -1;
    const tinygltf::Texture &t = model_.textures[gltf_texture];
    std::string what = "texture " + str(gltf_texture) + " of " + where;
    if (t.source < 0) {
        // an image only an extension names (KTX2 by KHR_texture_basisu, WebP, DDS): one ignored:
        // line per extension; with a PNG/JPEG fallback in `source` that fallback is read instead
        for (const auto &e : t.extensions)
            if (e.second.IsObject() && e.second.Has("source")) {
                note_ignored("textures whose only image is " + std::string(e.first == "KHR_texture_basisu" ? "KTX2 " : "") +
                                 "in " + printable(e.first), where);
                return result;
            }
        warn(what + " has no image source (extension images are not supported); ignored");
        return result;
    }
    const tinygltf::Image &image = model_.images[t.source];
    if (image.image.empty()) return result;  // tinygltf or load_wanted_image already warned why
    if (image.bits != 8) {
        warn(what + ": image " + str(t.source) + " has " + std::to_string(image.bits) +
             "-bit channels (only 8-bit is supported); ignored");
        return result;
    }
    size_t pixels = static_cast<size_t>(image.width) * static_cast<size_t>(image.height);
    if (image.width <= 0 || image.height <= 0 || image.component < 1 || image.component > 4 ||
        image.image.size() != pixels * static_cast<size_t>(image.component))
        fail("decoded image has inconsistent dimensions (image " + str(t.source) + ")");
    pm_texture tex;
    memset(&tex, 0, sizeof tex);
    tex.width = image.width;
    tex.height = image.height;
    tex.wrap_s = tex.wrap_t = PM_WRAP_REPEAT;
    if (t.sampler >= 0) {
        const tinygltf::Sampler &s = model_.samplers[t.sampler];
        int *wraps[2] = {&tex.wrap_s, &tex.wrap_t};
        int modes[2] = {s.wrapS, s.wrapT};
        const char *fields[2] = {"wrapS", "wrapT"};
        for (int k = 0; k < 2; k++) {
            if (modes[k] == TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE) *wraps[k] = PM_WRAP_CLAMP;
            else if (modes[k] == TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT) *wraps[k] = PM_WRAP_MIRROR;
            else if (modes[k] != TINYGLTF_TEXTURE_WRAP_REPEAT)
                note("sampler " + str(t.sampler), fields[k], std::to_string(modes[k]) + " is not a glTF wrap mode; using REPEAT",
                     false);  // a second texture on the same sampler
        }
        sampler_filters(s, t.sampler, &tex);
    }
    // one pm_texture per image and sampling (the fields above, texels not yet set): a PNG named by
    // 1,000 textures was copied, and its mip levels made, 1,000 times (5.4 GB from a 222 KB file)
    std::string key(reinterpret_cast<const char *>(&tex), sizeof tex);
    key += std::to_string(t.source);
    auto same = texture_of_image_.find(key);
    if (same != texture_of_image_.end()) return result = same->second;
    textures_.items.reserve(textures_.items.size() + 1);  // so push_back below cannot throw and leak the texels
    const uint64_t mark = pm_memory_failure_mark();
    if (!pm_memory_admit(static_cast<uint64_t>(pixels) * 4, "texture"))
        fail("out of memory (" + std::string(pm_memory_failure_since_or(mark, "texture")) + "): image " + str(t.source));
    admitted_.bytes += static_cast<uint64_t>(pixels) * 4;
    tex.rgba = static_cast<uint8_t *>(pm_malloc(pixels * 4, "texture"));
    if (!tex.rgba) throw std::bad_alloc();
    const unsigned char *src = image.image.data();
    size_t n = static_cast<size_t>(image.component);
    for (size_t i = 0; i < pixels; i++, src += n) {
        uint8_t *dst = tex.rgba + 4 * i;
        bool gray = n <= 2;
        dst[0] = src[0];
        dst[1] = gray ? src[0] : src[1];
        dst[2] = gray ? src[0] : src[2];
        dst[3] = n == 2 ? src[1] : (n == 4 ? src[3] : 255);
    }
    textures_.items.push_back(tex);
    result = static_cast<int>(textures_.items.size() - 1);
    texture_of_image_[key] = result;
    return result;
}

// One texture reference into the material's texture index, TEXCOORD set and uv transform. The
// transform is KHR_texture_transform's T * R * S, with the rotation as the sample model
// TextureTransformTest and the common viewers read it: a positive angle turns the UVs
// counter-clockwise as seen in glTF's v-down UV space (u' = cos u + sin v, v' = -sin u + cos v);
// the spec's GLSL listing has the opposite sign (KhronosGroup/glTF issue 1563).
// Returns false when the reference names a TEXCOORD set above 1 (TEXCOORD_0 is read instead).
bool Loader::convert_reference(const TextureReference &r, const std::string &where, int *texture, int *texcoord,
                               pm_uv_transform *transform) {
    *texture = -1;
    *texcoord = 0;
    memset(transform, 0, sizeof *transform);
    if (r.texture < 0) return true;
    *texture = texture_for(r.texture, where);
    if (*texture < 0) return true;
    if (r.texcoord <= 1) *texcoord = static_cast<int>(r.texcoord);
    if (*texcoord == 1) uv1_needed_ = true;
    if (!r.transformed) return r.texcoord <= 1;
    double c = std::cos(r.rotation), s = std::sin(r.rotation);
    const double m[6] = {c * r.scale[0], s * r.scale[1], r.offset[0], -s * r.scale[0], c * r.scale[1], r.offset[1]};
    transform->transformed = true;
    for (int k = 0; k < 6; k++) {
        transform->m[k] = static_cast<float>(m[k]);
        if (!std::isfinite(transform->m[k])) fail("KHR_texture_transform overflows a float (" + where + ")");
    }
    return r.texcoord <= 1;
}

// KHR_materials_specular, _sheen and _clearcoat (pm_material_layers): factors and textures, the
// coat's own normal texture with its scale. A material is layered when one of them is present.
// Returns convert_reference's verdict on the TEXCOORD sets.
bool Loader::convert_layers(const tinygltf::Material &mat, const std::array<TextureReference, kReferenceKinds> &refs,
                            const std::string &label, const std::string &name, pm_material *m) {
    const tinygltf::ExtensionMap &x = mat.extensions;
    bool specular = x.count("KHR_materials_specular"), sheen = x.count("KHR_materials_sheen"),
         clearcoat = x.count("KHR_materials_clearcoat");
    if (!specular && !sheen && !clearcoat) return true;
    pm_material_layers &l = m->layers;
    m->layered = true;
    // a colour member: 3 numbers (their type checked in the preflight), each within [0, top]
    auto color = [&](const char *extension, const char *key, float fallback, double top, const char *field) {
        double v[3] = {fallback, fallback, fallback};
        auto it = x.find(extension);
        if (it != x.end() && it->second.IsObject() && it->second.Has(key)) {
            const tinygltf::Value &c = it->second.Get(key);
            for (int k = 0; k < 3 && c.IsArray() && c.ArrayLen() == 3; k++)
                v[k] = checked(c.Get(k).GetNumberAsDouble(), 0, top, field, label);
        }
        return v3(static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2]));
    };
    l.specular = static_cast<float>(checked(extension_number(x, "KHR_materials_specular", "specularFactor", 1), 0, 1,
                                            "KHR_materials_specular specularFactor", label));
    l.specular_color = color("KHR_materials_specular", "specularColorFactor", 1.f, FLT_MAX,
                             "KHR_materials_specular specularColorFactor");
    l.sheen_color = color("KHR_materials_sheen", "sheenColorFactor", 0.f, 1, "KHR_materials_sheen sheenColorFactor");
    l.sheen_roughness = static_cast<float>(checked(extension_number(x, "KHR_materials_sheen", "sheenRoughnessFactor", 0), 0,
                                                   1, "KHR_materials_sheen sheenRoughnessFactor", label));
    l.clearcoat = static_cast<float>(checked(extension_number(x, "KHR_materials_clearcoat", "clearcoatFactor", 0), 0, 1,
                                             "KHR_materials_clearcoat clearcoatFactor", label));
    l.clearcoat_roughness = static_cast<float>(checked(extension_number(x, "KHR_materials_clearcoat", "clearcoatRoughnessFactor", 0),
                                                       0, 1, "KHR_materials_clearcoat clearcoatRoughnessFactor", label));
    l.clearcoat_normal_scale = 1.f;
    if (clearcoat && x.at("KHR_materials_clearcoat").IsObject() && x.at("KHR_materials_clearcoat").Has("clearcoatNormalTexture")) {
        const tinygltf::Value &t = x.at("KHR_materials_clearcoat").Get("clearcoatNormalTexture");
        if (t.IsObject() && t.Has("scale") && t.Get("scale").IsNumber())
            l.clearcoat_normal_scale = static_cast<float>(
                checked(t.Get("scale").GetNumberAsDouble(), -FLT_MAX, FLT_MAX, "clearcoatNormalTexture scale", label));
    }
    std::string where = label;
    struct { int kind; pm_texture_ref *into; } textures[] = {
        {kSpecular, &l.specular_texture}, {kSpecularColor, &l.specular_color_texture}, {kSheenColor, &l.sheen_color_texture},
        {kSheenRoughness, &l.sheen_roughness_texture}, {kClearcoat, &l.clearcoat_texture},
        {kClearcoatRoughness, &l.clearcoat_roughness_texture}, {kClearcoatNormal, &l.clearcoat_normal_texture}};
    bool sets_ok = true;
    for (const auto &t : textures)
        sets_ok &= convert_reference(refs[t.kind], where, &t.into->texture, &t.into->texcoord, &t.into->transform);
    return sets_ok;
}

void Loader::convert_materials() {
    for (size_t i = 0; i < model_.materials.size(); i++) {
        const tinygltf::Material &mat = model_.materials[i];
        const tinygltf::PbrMetallicRoughness &pbr = mat.pbrMetallicRoughness;
        std::string where = "material " + str(i);
        /* what this material asks for that pmview does not render: warned once per kind below */
        std::string name = mat.name.empty() ? where : "material " + str(i) + " " + printable(mat.name);
        if (mat.occlusionTexture.index >= 0) occlusion_textures_ignored_++;
        for (const auto &e : mat.extensions)
            if (e.first != "KHR_materials_transmission" && e.first != "KHR_materials_emissive_strength" &&
                e.first != "KHR_materials_ior" && e.first != "KHR_materials_volume" && e.first != "KHR_materials_clearcoat" &&
                e.first != "KHR_materials_sheen" && e.first != "KHR_materials_specular" && e.first != "KHR_materials_unlit")
                note_ignored(e.first, name);
        pm_material m;
        pm_material_set_default(&m);  // a field not read from the file below keeps glTF's default
        std::string label = material_label(i);
        float base[3];  // in order, so the warning quotes the first value clamped
        for (int k = 0; k < 3; k++) base[k] = static_cast<float>(checked(pbr.baseColorFactor[k], 0, 1, "baseColorFactor", label));
        m.base_color = v3(base[0], base[1], base[2]);
        m.metallic = static_cast<float>(checked(pbr.metallicFactor, 0, 1, "metallicFactor", label));
        m.roughness = static_cast<float>(checked(pbr.roughnessFactor, 0, 1, "roughnessFactor", label));
        m.transmission = static_cast<float>(
            checked(extension_number(mat.extensions, "KHR_materials_transmission", "transmissionFactor", 0), 0, 1,
                    "KHR_materials_transmission transmissionFactor", label));
        m.ior = static_cast<float>(
            checked(extension_number(mat.extensions, "KHR_materials_ior", "ior", 1.5), 1, FLT_MAX, "KHR_materials_ior ior", label));
        double strength = checked(extension_number(mat.extensions, "KHR_materials_emissive_strength", "emissiveStrength", 1),
                                  0, INFINITY, "KHR_materials_emissive_strength emissiveStrength", label);
        double factor[3];
        for (int k = 0; k < 3; k++) factor[k] = checked(mat.emissiveFactor[k], 0, 1, "emissiveFactor", label);
        m.emission = emission_within_film(factor, strength, "emission", "emissiveFactor x emissiveStrength " + num(strength), label);
        m.double_sided = mat.doubleSided;
        // KHR_materials_unlit: base colour as it is, for the camera alone; the extension says every
        // other input is ignored, emission included (docs/design.md, Materials)
        m.unlit = mat.extensions.count("KHR_materials_unlit") > 0;
        if (m.unlit) m.emission = v3s(0.f);
        attenuation_.emplace_back();
        m.thin_walled = !volume_attenuation(mat.extensions, label, attenuation_.back().data());
        m.alpha = static_cast<float>(checked(pbr.baseColorFactor[3], 0, 1, "baseColorFactor", label));
        m.alpha_cutoff = static_cast<float>(checked(mat.alphaCutoff, 0, FLT_MAX, "alphaCutoff", label));
        if (mat.alphaMode == "MASK") m.alpha_mode = PM_ALPHA_MASK;
        else if (mat.alphaMode == "BLEND") m.alpha_mode = PM_ALPHA_BLEND;
        else if (mat.alphaMode != "OPAQUE")
            warn(label + " has unknown alphaMode " + printable(mat.alphaMode) + "; treated as OPAQUE");
        const std::array<TextureReference, kReferenceKinds> &refs = references_[i];
        TextureReference none;
        bool sets_ok = convert_reference(refs[kBaseColor], where, &m.base_color_texture, &m.base_color_texcoord,
                                         &m.base_color_transform);
        // an emissive texture times a black factor, or a transmission texture times 0, is never read
        bool emits = m.emission.x > 0 || m.emission.y > 0 || m.emission.z > 0;
        sets_ok &= convert_reference(emits ? refs[kEmissive] : none, where, &m.emission_texture, &m.emission_texcoord,
                                     &m.emission_transform);
        sets_ok &= convert_reference(refs[kMetallicRoughness], where, &m.metallic_roughness_texture,
                                     &m.metallic_roughness_texcoord, &m.metallic_roughness_transform);
        sets_ok &= convert_reference(m.transmission > 0 ? refs[kTransmission] : none, where, &m.transmission_texture,
                                     &m.transmission_texcoord, &m.transmission_transform);
        sets_ok &= convert_reference(refs[kNormal], where, &m.normal_texture, &m.normal_texcoord, &m.normal_transform);
        m.normal_scale = static_cast<float>(checked(mat.normalTexture.scale, -FLT_MAX, FLT_MAX, "normalTexture scale", label));
        if (m.normal_texture >= 0) tangents_needed_ = true;
        sets_ok &= convert_layers(mat, refs, label, name, &m);
        if (pm_material_coat_normal_mapped(&m)) tangents_needed_ = true;
        if (!sets_ok) note_ignored("texture coordinate sets above TEXCOORD_1 (TEXCOORD_0 is read instead)", name);
        materials_.push_back(m);
    }
    for (const auto &k : ignored_)
        warn("ignored: " + k.first + " in " + str(k.second.count) + " material(s), first " + k.second.first);
}

// KHR_materials_variants: with a variant asked for, every primitive whose mappings name it takes
// the mapped material (the preflight checked the material indices); the others keep their default.
// A name the file's root list does not hold fails the load with the names it does hold.
void Loader::apply_variant() {
    std::vector<std::string> names;
    auto root = model_.extensions.find("KHR_materials_variants");
    if (root != model_.extensions.end() && root->second.IsObject() && root->second.Has("variants")) {
        const tinygltf::Value &list = root->second.Get("variants");
        for (size_t k = 0; list.IsArray() && k < list.ArrayLen(); k++) {
            const tinygltf::Value &v = list.Get(static_cast<int>(k));
            names.push_back(v.IsObject() && v.Has("name") && v.Get("name").IsString() ? v.Get("name").Get<std::string>() : "");
        }
    }
    // the names for the window's variant key, which reloads the file with one of them (an
    // embedded '\0' would cut a name short: such a name stays reachable by --variant alone)
    for (const std::string &n : names) {
        variant_names_.insert(variant_names_.end(), n.begin(), n.end());
        variant_names_.push_back('\0');
    }
    variant_count_ = static_cast<uint32_t>(names.size());
    if (!options_.variant) return;
    const std::string wanted = options_.variant;
    int index = -1;
    for (size_t k = 0; k < names.size() && index < 0; k++)
        if (names[k] == wanted) index = static_cast<int>(k);
    if (index < 0) {
        std::string known;
        for (const std::string &n : names) known += (known.empty() ? "" : ", ") + printable(n);
        fail("no material variant " + printable(wanted) + " (KHR_materials_variants lists " +
             (names.empty() ? std::string("none") : known) + ")");
    }
    for (tinygltf::Mesh &mesh : model_.meshes)
        for (tinygltf::Primitive &prim : mesh.primitives) {
            auto ext = prim.extensions.find("KHR_materials_variants");
            if (ext == prim.extensions.end() || !ext->second.IsObject() || !ext->second.Has("mappings")) continue;
            const tinygltf::Value &mappings = ext->second.Get("mappings");
            for (size_t k = 0; mappings.IsArray() && k < mappings.ArrayLen(); k++) {
                const tinygltf::Value &m = mappings.Get(static_cast<int>(k));
                if (!m.IsObject() || !m.Has("material") || !m.Get("material").IsNumber() || !m.Has("variants")) continue;
                const tinygltf::Value &vs = m.Get("variants");
                for (size_t j = 0; vs.IsArray() && j < vs.ArrayLen(); j++)
                    if (vs.Get(static_cast<int>(j)).IsNumber() && vs.Get(static_cast<int>(j)).GetNumberAsInt() == index)
                        prim.material = m.Get("material").GetNumberAsInt();
            }
        }
}

// The material of primitives without one: glTF's default (white, fully metallic and rough).
void Loader::add_default_material() {
    pm_material m;
    pm_material_set_default(&m);
    materials_.push_back(m);
}

// ---------------- geometry: primitives decoded, meshes appended as triangles through a transform

enum class VertexRole { kPosition, kNormal, kTexcoord, kTangent };

// Component types a vertex attribute may use. Core glTF: float everywhere, and normalized
// u8/u16 for texture coordinates. KHR_mesh_quantization adds: positions and texture coordinates
// of any byte/short type, normalized or not; normals of normalized i8/i16 (read_component
// dequantizes the normalized ones with glTF's formulas); tangents like normals.
bool vertex_type_allowed(const AccessorLayout &l, VertexRole role, bool quantization) {
    int t = l.component_type;
    if (t == TINYGLTF_COMPONENT_TYPE_FLOAT) return true;
    bool signed_int = t == TINYGLTF_COMPONENT_TYPE_BYTE || t == TINYGLTF_COMPONENT_TYPE_SHORT;
    bool unsigned_int = t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE || t == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
    switch (role) {
    case VertexRole::kPosition: return quantization && (signed_int || unsigned_int);
    case VertexRole::kNormal:
    case VertexRole::kTangent: return quantization && signed_int && l.normalized;
    case VertexRole::kTexcoord: return (unsigned_int && l.normalized) || (quantization && (signed_int || unsigned_int));
    }
    return false;
}

// A NORMAL value that gives a direction (mesh space; the node's transform may still collapse it).
bool usable_normal(const float *n) {
    double length = std::sqrt(static_cast<double>(n[0]) * n[0] + static_cast<double>(n[1]) * n[1] +
                              static_cast<double>(n[2]) * n[2]);
    return length > 0 && std::isfinite(length);
}

int attribute(const tinygltf::Primitive &prim, const char *name) {
    auto it = prim.attributes.find(name);
    return it == prim.attributes.end() ? -1 : it->second;
}

DecodedPrimitive Loader::decode_primitive(int mesh, int index) {
    const tinygltf::Primitive &prim = model_.meshes[mesh].primitives[index];
    PrimitiveSource source = {mesh, index, prim, "mesh " + str(mesh) + " primitive " + str(index), 0};
    DecodedPrimitive out;
    if (prim.mode < TINYGLTF_MODE_TRIANGLES) return out;
    out.triangles = true;
    out.material = prim.material >= 0 ? static_cast<uint32_t>(prim.material)
                                       : static_cast<uint32_t>(model_.materials.size());
    if (prim.material < 0) default_material_used_ = true;
    source.vertices = read_positions(source, &out);
    read_vertex_attributes(source, &out);
    apply_morph_targets(source, &out);
    round_tangent_signs(source, &out);
    assemble_corners(prim, read_index_sequence(source), source.where, &out);
    flatten_unusable_normals(source, &out);
    return out;
}

// POSITION, every value finite; returns the vertex count.
size_t Loader::read_positions(const PrimitiveSource &source, DecodedPrimitive *out) {
    const std::string &where = source.where;
    int position = attribute(source.prim, "POSITION");
    if (position < 0) fail("triangles without a POSITION attribute (" + where + ")");
    AccessorLayout pl = accessor_layout(model_, position);
    if (pl.components != 3 || !vertex_type_allowed(pl, VertexRole::kPosition, quantization_))
        fail(std::string("POSITION must be a float VEC3") +
             (quantization_ ? " or (KHR_mesh_quantization) a byte/short one" : "") + " (accessor " + str(position) +
             ", " + where + ")");
    if (pl.count > UINT32_MAX) fail("more than 2^32 vertices (" + where + ")");
    out->positions = read_accessor<float>(pl, position);
    for (size_t i = 0; i < out->positions.size(); i++)
        if (!std::isfinite(out->positions[i]))
            fail("non-finite vertex position at vertex " + str(i / 3) + " (POSITION accessor " + str(position) + ", " +
                 where + ")");
    return pl.count;
}

// NORMAL, TEXCOORD_0, and where something reads them TEXCOORD_1 and TANGENT: each of an allowed
// type and of POSITION's count.
void Loader::read_vertex_attributes(const PrimitiveSource &source, DecodedPrimitive *out) {
    const std::string &where = source.where;
    struct { const char *name; int components; VertexRole role; std::vector<float> *into; } optional[] = {
        {"NORMAL", 3, VertexRole::kNormal, &out->normals}, {"TEXCOORD_0", 2, VertexRole::kTexcoord, &out->uvs},
        {"TEXCOORD_1", 2, VertexRole::kTexcoord, uv1_needed_ ? &out->uvs1 : nullptr},  // only when a texture reads it
        {"TANGENT", 4, VertexRole::kTangent, tangents_needed_ ? &out->tangents : nullptr}};  // only with a normal map
    for (const auto &o : optional) {
        int a = attribute(source.prim, o.name);
        if (a < 0 || !o.into) continue;
        AccessorLayout l = accessor_layout(model_, a);
        bool texcoord = o.role == VertexRole::kTexcoord;
        const char *vec = o.components == 4 ? "VEC4" : "VEC3";
        if (l.components != o.components || !vertex_type_allowed(l, o.role, quantization_))
            fail(std::string(o.name) + " must be " +
                 (texcoord ? std::string("a float or normalized u8/u16 VEC2") : std::string("a float ") + vec) +
                 (quantization_ ? (texcoord ? std::string(" or (KHR_mesh_quantization) any byte/short VEC2")
                                            : std::string(" or (KHR_mesh_quantization) a normalized byte/short ") + vec)
                                : std::string()) +
                 " (accessor " + str(a) + ", " + where + ")");
        if (l.count != source.vertices)
            fail(std::string(o.name) + " count " + str(l.count) + " != POSITION count " + str(source.vertices) + " (" +
                 where + ")");
        *o.into = read_accessor<float>(l, a);
        // a NaN or infinite texture coordinate reads as an arbitrary texel (white, or an emissive
        // texture glowing at full strength): read as 0, counted in one warning
        if (texcoord)
            for (size_t i = 0; i < o.into->size(); i++)
                if (!std::isfinite((*o.into)[i])) {
                    if (nonfinite_uvs_++ == 0) first_nonfinite_uv_ = std::string(o.name) + " vertex " + str(i / 2) + ", " + where;
                    (*o.into)[i] = 0.f;
                }
    }
}

// Morph targets at the mesh's default weights: glTF's static pose is the base plus each
// target's POSITION and NORMAL displacements times mesh.weights (a morphed mesh rendered its
// base shape before). One pose a mesh: a node's own weights, when they differ, are warned of (load).
void Loader::apply_morph_targets(const PrimitiveSource &source, DecodedPrimitive *out) {
    const tinygltf::Primitive &prim = source.prim;
    const std::vector<double> &weights = model_.meshes[source.mesh].weights;
    for (size_t t = 0; t < prim.targets.size() && t < weights.size(); t++) {
        if (!(weights[t] != 0)) continue;
        if (!std::isfinite(weights[t])) fail("non-finite weight " + str(t) + " (mesh " + str(source.mesh) + ")");
        for (const char *name : {"POSITION", "NORMAL"}) {
            auto it = prim.targets[t].find(name);
            std::vector<float> &into = name[0] == 'P' ? out->positions : out->normals;
            if (it == prim.targets[t].end() || into.empty()) continue;
            std::string target = std::string(name) + " of morph target " + str(t) + " (accessor " + str(it->second) + ", " +
                                 source.where + ")";
            AccessorLayout l = accessor_layout(model_, it->second);
            if (l.components != 3 || (l.component_type != TINYGLTF_COMPONENT_TYPE_FLOAT && !quantization_))
                fail("the " + target + " must be a float VEC3" + (quantization_ ? " or a byte/short one" : ""));
            if (l.count != source.vertices)
                fail("the " + target + " has count " + str(l.count) + ", POSITION " + str(source.vertices));
            std::vector<float> delta = read_accessor<float>(l, it->second);
            for (size_t i = 0; i < into.size() && i < delta.size(); i++) {
                into[i] = static_cast<float>(into[i] + weights[t] * delta[i]);
                if (!std::isfinite(into[i])) fail("the " + target + " at weight " + num(weights[t]) + " makes vertex " + str(i / 3) + " non-finite");
            }
        }
    }
}

// glTF: TANGENT's w is +1 or -1. Any other is read by its sign (0 and NaN as +1), counted in
// one warning; only where a normal map reads it.
void Loader::round_tangent_signs(const PrimitiveSource &source, DecodedPrimitive *out) {
    const tinygltf::Primitive &prim = source.prim;
    bool mapped = !out->tangents.empty() && prim.material >= 0 && pm_material_tangents_read(&materials_[prim.material]);
    uint64_t odd_w = 0;
    size_t first_odd = 0;
    float first_w = 0;
    for (size_t i = 0; mapped && i < source.vertices; i++) {
        float &w = out->tangents[4 * i + 3];
        if (w == 1.f || w == -1.f) continue;
        if (odd_w++ == 0) {
            first_odd = i;
            first_w = w;
        }
        w = w < 0 ? -1.f : 1.f;
    }
    if (odd_w)
        warn(mesh_label(source.mesh, source.index) + " TANGENT: " + str(odd_w) + " of its " + str(source.vertices) +
             " w values are not +1 or -1 (first " + num(first_w) + " at vertex " + str(first_odd) +
             "); read by their sign, 0 or NaN as +1");
}

// The vertex sequence: the indices accessor's, each below the vertex count, or 0, 1, 2, ...
std::vector<uint32_t> Loader::read_index_sequence(const PrimitiveSource &source) {
    const tinygltf::Primitive &prim = source.prim;
    std::vector<uint32_t> sequence;
    if (prim.indices >= 0) {
        AccessorLayout il = accessor_layout(model_, prim.indices);
        if (il.components != 1 || (il.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                                   il.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                                   il.component_type != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
            fail("indices must be UNSIGNED_BYTE/SHORT/INT scalars, got componentType " + str(il.component_type) +
                 " (accessor " + str(prim.indices) + ", " + source.where + ")");
        sequence = read_accessor<uint32_t>(il, prim.indices);
        for (uint32_t i : sequence)
            if (i >= source.vertices)
                fail("index " + str(i) + " >= vertex count " + str(source.vertices) + " (" + source.where + ")");
    } else {
        sequence.resize(source.vertices);
        for (size_t i = 0; i < source.vertices; i++) sequence[i] = static_cast<uint32_t>(i);
    }
    return sequence;
}

// The triangles' corners from the vertex sequence of a triangle list, strip or fan.
void Loader::assemble_corners(const tinygltf::Primitive &prim, const std::vector<uint32_t> &sequence,
                              const std::string &where, DecodedPrimitive *out) {
    size_t n = sequence.size();
    if (prim.mode == TINYGLTF_MODE_TRIANGLES) {
        out->corners.assign(sequence.begin(), sequence.begin() + static_cast<long>(n / 3 * 3));
        if (n % 3) warn("ignored " + str(n % 3) + " trailing index(es) that do not form a triangle (" + where + ")");
    } else if (n >= 3) {
        out->corners.reserve((n - 2) * 3);
        for (size_t i = 0; i + 2 < n; i++) {
            // the glTF spec's orderings, which keep every triangle's winding consistent
            uint32_t tri[3];
            if (prim.mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
                tri[0] = sequence[i];
                tri[1] = sequence[i + 1 + i % 2];
                tri[2] = sequence[i + 2 - i % 2];
            } else {
                tri[0] = sequence[i + 1];
                tri[1] = sequence[i + 2];
                tri[2] = sequence[0];
            }
            out->corners.insert(out->corners.end(), tri, tri + 3);
        }
    }
}

// glTF gives a primitive without NORMAL flat normals; a NORMAL of zero length or not finite
// says as little, so each triangle with such a corner is flat too (its own three vertices
// with the face normal): the same shading as without NORMAL, where the file gives nothing.
void Loader::flatten_unusable_normals(const PrimitiveSource &source, DecodedPrimitive *out) {
    if (out->normals.empty()) return;
    uint64_t unusable = 0;
    size_t first = 0;
    for (size_t i = 0; i < source.vertices; i++)
        if (!usable_normal(&out->normals[3 * i]) && unusable++ == 0) first = i;
    for (size_t t = 0; unusable && t < out->corners.size(); t += 3)
        for (int k = 0; k < 3; k++)
            if (!usable_normal(&out->normals[3 * out->corners[t + k]])) {
                out->flat_triangles++;
                break;
            }
    if (unusable)
        warn(mesh_label(source.mesh, source.index) + " NORMAL: " + str(unusable) + " of its " + str(source.vertices) +
             " values have zero length or are not finite (first (" + num(out->normals[3 * first]) + ", " +
             num(out->normals[3 * first + 1]) + ", " + num(out->normals[3 * first + 2]) + ") at vertex " + str(first) +
             "); the " + str(out->flat_triangles) + " triangle(s) with such a corner get flat normals, as without NORMAL");
}

const DecodedMesh &Loader::decoded_mesh(int mesh) {
    if (!meshes_[mesh]) {
        std::unique_ptr<DecodedMesh> d(new DecodedMesh);
        for (size_t p = 0; p < model_.meshes[mesh].primitives.size(); p++) {
            d->primitives.push_back(decode_primitive(mesh, static_cast<int>(p)));
            const DecodedPrimitive &prim = d->primitives.back();
            uint64_t tris = prim.corners.size() / 3;
            d->triangles += tris;
            d->vertices += prim.normals.empty() ? 3 * tris : prim.positions.size() / 3 + 3 * prim.flat_triangles;
        }
        meshes_[mesh] = std::move(d);
    }
    return *meshes_[mesh];
}

// Each placed mesh decoded once, however often it is placed; returns how many placements each mesh has.
std::vector<uint32_t> Loader::decode_placed_meshes() {
    std::vector<uint32_t> uses(model_.meshes.size(), 0);
    for (const Instance &instance : instances_) {
        uses[instance.mesh]++;
        decoded_mesh(instance.mesh);
        const std::vector<double> &own = model_.nodes[instance.node].weights;
        if (!own.empty() && own != model_.meshes[instance.mesh].weights && !node_weights_warned_) {
            node_weights_warned_ = true;
            warn("node " + str(instance.node) + " gives mesh " + str(instance.mesh) +
                 " morph weights of its own: the mesh's default weights are rendered (one pose a mesh)");
        }
    }
    return uses;
}

// Appends the mesh's triangles through `transform`: the node's world transform for a flat copy,
// the identity for an instanced mesh's one stored copy.
void Loader::instance_mesh(const Instance &instance, const Mat4 &transform) {
    const DecodedMesh &mesh = *meshes_[instance.mesh];
    WorldTransform world(transform);
    for (size_t p = 0; p < mesh.primitives.size(); p++) {
        const DecodedPrimitive &prim = mesh.primitives[p];
        if (!prim.triangles) {
            skipped_prims_++;
            continue;
        }
        std::string where = "mesh " + str(instance.mesh) + " primitive " + str(p) + " on node " + str(instance.node);
        PlacedPrimitive placed(prim);
        place_vertices(&placed, world, where);
        place_tangents(&placed, world);
        size_t count = placed.positions.size();
        placed.base = static_cast<uint32_t>(positions_.size());
        if (!placed.flat)
            for (size_t i = 0; i < count; i++) append_vertex(placed, i, placed.normals[i]);
        for (size_t t = 0; t < prim.corners.size(); t += 3) place_triangle(&placed, world.mirrored, t);
        uint32_t base = placed.base;
        if (!placed.flat)  // a shared vertex without a direction serves no triangle; it still holds a unit normal
            for (size_t i = base; i < base + count; i++)
                if (v3_is_black(normals_[i])) normals_[i] = v3(0, 0, 1);
        for (size_t i = 0; i < placed.du_sum.size(); i++)
            set_tangent(base + i, placed.du_sum[i], normals_[base + i], placed.hand_sum[i] < 0 ? -1.f : 1.f);
    }
}

// The primitive's positions and normals through the transform; flat when it has no NORMAL or none
// keeps a direction.
void Loader::place_vertices(PlacedPrimitive *placed, const WorldTransform &world, const std::string &where) {
    const DecodedPrimitive &prim = placed->prim;
    size_t count = prim.positions.size() / 3;
    placed->positions.resize(count);
    for (size_t i = 0; i < count; i++) {
        placed->positions[i] = world.point(&prim.positions[3 * i]);
        if (!v3_is_finite(placed->positions[i])) fail("vertex position overflows after the transform (" + where + ")");
    }
    placed->flat = prim.normals.empty();
    if (!placed->flat) {
        std::vector<vec3> &normals = placed->normals;
        normals.resize(count);
        for (size_t i = 0; i < count; i++) {
            const double n[3] = {prim.normals[3 * i], prim.normals[3 * i + 1], prim.normals[3 * i + 2]};
            normals[i] = world.unit(n, true);  // (0,0,0): no direction, its triangles are flat
            if (v3_is_black(normals[i]) && usable_normal(&prim.normals[3 * i]) && collapsed_normals_++ == 0)
                first_collapsed_ = where;
        }
        // no direction anywhere: exactly the primitive without NORMAL, without unused shared vertices
        placed->flat = std::all_of(normals.begin(), normals.end(), [](vec3 n) { return v3_is_black(n); });
    }
    placed->has_uv = !prim.uvs.empty();
    placed->has_uv1 = !prim.uvs1.empty();
    any_uv_ = any_uv_ || placed->has_uv;
    any_uv1_ = any_uv1_ || placed->has_uv1;
}

// Tangents for a normal-mapped material: TANGENT transformed like a direction (its w flips with a
// mirroring transform, as the bitangent w cross(n, t) would), else generated by place_triangle
// from the positions and the normal texture's UV set.
void Loader::place_tangents(PlacedPrimitive *placed, const WorldTransform &world) {
    const DecodedPrimitive &prim = placed->prim;
    size_t count = placed->positions.size();
    const pm_material &material = materials_[prim.material];
    placed->mapped = tangents_needed_ && pm_material_tangents_read(&material);
    placed->given_tangents = placed->mapped && !prim.tangents.empty();
    placed->tangent_uvs = pm_material_tangent_texcoord(&material) == 1 ? &prim.uvs1 : &prim.uvs;
    if (placed->given_tangents) {
        std::vector<float> &tangents = placed->tangents;
        tangents.resize(4 * count);
        for (size_t i = 0; i < count; i++) {
            const double d[3] = {prim.tangents[4 * i], prim.tangents[4 * i + 1], prim.tangents[4 * i + 2]};
            vec3 t = world.unit(d, false);  // (0,0,0): no usable tangent, the scene picks a frame
            tangents[4 * i] = t.x;
            tangents[4 * i + 1] = t.y;
            tangents[4 * i + 2] = t.z;
            tangents[4 * i + 3] = (prim.tangents[4 * i + 3] < 0) != world.mirrored ? -1.f : 1.f;
        }
    }
    // generated: per vertex, the sum of its triangles' dp/du scaled by |det| (so weighted by
    // their UV area) and of their handedness votes (weighted by area)
    placed->du_sum.assign(placed->mapped && !placed->given_tangents && !placed->flat ? count : 0, v3s(0.f));
    placed->hand_sum.assign(placed->du_sum.size(), 0.0);
}

// Appends vertex i of the placed primitive with the given normal to the scene's vertex arrays.
void Loader::append_vertex(const PlacedPrimitive &placed, size_t i, vec3 normal) {
    const DecodedPrimitive &prim = placed.prim;
    positions_.push_back(placed.positions[i]);
    normals_.push_back(normal);
    if (tangents_needed_)
        for (int k = 0; k < 4; k++) tangents_.push_back(placed.given_tangents ? placed.tangents[4 * i + k] : (k == 3 ? 1.f : 0.f));
    uvs_.push_back(placed.has_uv ? prim.uvs[2 * i] : 0.f);
    uvs_.push_back(placed.has_uv ? prim.uvs[2 * i + 1] : 0.f);
    if (uv1_needed_) {
        uvs1_.push_back(placed.has_uv1 ? prim.uvs1[2 * i] : 0.f);
        uvs1_.push_back(placed.has_uv1 ? prim.uvs1[2 * i + 1] : 0.f);
    }
}

// The unit face normal of corners c and the length of their edges' cross product, in double: edges
// of a tiny triangle square to below a float's range, a huge one's above it. False when degenerate.
bool face_normal(const std::vector<vec3> &positions, const uint32_t c[3], vec3 *face, double *length) {
    double e1[3], e2[3], cross[3];
    for (int k = 0; k < 3; k++) {
        e1[k] = static_cast<double>(v3_get(positions[c[1]], k)) - v3_get(positions[c[0]], k);
        e2[k] = static_cast<double>(v3_get(positions[c[2]], k)) - v3_get(positions[c[0]], k);
    }
    for (int k = 0; k < 3; k++) cross[k] = e1[(k + 1) % 3] * e2[(k + 2) % 3] - e1[(k + 2) % 3] * e2[(k + 1) % 3];
    *length = std::sqrt(cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]);
    if (!(*length > 0) || !std::isfinite(*length)) return false;
    *face = v3(static_cast<float>(cross[0] / *length), static_cast<float>(cross[1] / *length),
               static_cast<float>(cross[2] / *length));
    return true;
}

// p - p0 = dp/du (u - u0) + dp/dv (v - v0) on the triangle, solved for dp/du (times |det|: along
// +u, weighted by the triangle's UV area); glTF's v runs down the image and the map's +y up it, so
// the bitangent is -dp/dv and w = sign((n x dp/du) . -dp/dv) = -sign(det) with n along cross(e1, e2).
// A triangle without a UV mapping leaves du 0 and gives no vote (hand 0).
void uv_tangent(const std::vector<vec3> &positions, const float *uv, const uint32_t c[3], vec3 *du, float *hand) {
    double du1 = uv[2 * c[1]] - uv[2 * c[0]], dv1 = uv[2 * c[1] + 1] - uv[2 * c[0] + 1];
    double du2 = uv[2 * c[2]] - uv[2 * c[0]], dv2 = uv[2 * c[2] + 1] - uv[2 * c[0] + 1];
    double det = du1 * dv2 - du2 * dv1;
    vec3 e1 = v3_sub(positions[c[1]], positions[c[0]]), e2 = v3_sub(positions[c[2]], positions[c[0]]);
    if (det != 0 && std::isfinite(det)) {
        float sign = det > 0 ? 1.f : -1.f;
        *du = v3_scale(v3_sub(v3_scale(e1, static_cast<float>(dv2)), v3_scale(e2, static_cast<float>(dv1))), sign);
        *hand = -sign;
    }
}

// The triangle at corners t..t+2: dropped when degenerate, else its indices (shared vertices, or
// vertices of its own when flat), material and tangent contribution.
void Loader::place_triangle(PlacedPrimitive *placed, bool mirrored, size_t t) {
    const DecodedPrimitive &prim = placed->prim;
    uint32_t c[3] = {prim.corners[t], prim.corners[t + 1], prim.corners[t + 2]};
    if (mirrored) std::swap(c[1], c[2]);
    vec3 face;
    double length;
    if (!face_normal(placed->positions, c, &face, &length)) {
        degenerate_++;
        return;
    }
    vec3 du = v3s(0.f);  // dp/du x |det|: along +u, weighted by the triangle's UV area
    float hand = 0.f;  // no vote from a triangle without a UV mapping
    bool generated = placed->mapped && !placed->given_tangents;
    if (generated && !placed->tangent_uvs->empty()) uv_tangent(placed->positions, placed->tangent_uvs->data(), c, &du, &hand);
    // without NORMAL, or with a corner whose NORMAL gives no direction: flat, on vertices of its own
    const std::vector<vec3> &normals = placed->normals;
    bool flat_triangle = placed->flat || v3_is_black(normals[c[0]]) || v3_is_black(normals[c[1]]) || v3_is_black(normals[c[2]]);
    if (!placed->du_sum.empty() && !flat_triangle)
        for (int k = 0; k < 3; k++) {
            placed->du_sum[c[k]] = v3_add(placed->du_sum[c[k]], du);
            placed->hand_sum[c[k]] += hand * length;
        }
    for (int k = 0; k < 3; k++) {
        if (flat_triangle) {
            indices_.push_back(static_cast<uint32_t>(positions_.size()));
            append_vertex(*placed, c[k], face);
            if (generated) set_tangent(positions_.size() - 1, du, face, hand < 0 ? -1.f : 1.f);
        } else {
            indices_.push_back(placed->base + c[k]);
        }
    }
    triangle_material_.push_back(prim.material);
}

// ---------------- instancing: GPU instance sets, the meshes stored once, their placements

// EXT_mesh_gpu_instancing on a node with a mesh: the mesh is placed once per instance, at the
// node's transform times the instance's translation x rotation x scale, instead of at the node.
// Refused as a node's transform is: an attribute of the wrong type, counts that differ, a value
// not finite, a rotation of zero length. An instance with a zero scale places nothing (it would
// only make degenerate triangles): left out, counted in one warning.
void Loader::read_instance_set(int node_index, const tinygltf::Node &node, const tinygltf::Value &extension) {
    std::string where = "node " + str(node_index) + " EXT_mesh_gpu_instancing";
    InstanceSet set;
    set.node = node_index;
    auto admit = [&](uint64_t bytes) {
        const uint64_t mark = pm_memory_failure_mark();
        if (!pm_memory_admit(bytes, "GPU instances"))
            fail("out of memory (" + std::string(pm_memory_failure_since_or(mark, "GPU instances")) + ") (" + where + ")");
        decoded_.bytes += bytes;
    };
    struct { const char *name; int components; std::vector<float> *into; } parts[] = {
        {"TRANSLATION", 3, &set.translation}, {"ROTATION", 4, &set.rotation}, {"SCALE", 3, &set.scale}};
    const tinygltf::Value &attributes = extension.Get("attributes");
    uint64_t count = 0;
    bool any = false;
    for (const auto &part : parts) {
        if (!attributes.IsObject() || !attributes.Has(part.name)) continue;
        int a = attributes.Get(part.name).GetNumberAsInt();  // range-checked in the preflight
        AccessorLayout l = accessor_layout(model_, a);
        bool is_float = l.component_type == TINYGLTF_COMPONENT_TYPE_FLOAT;
        // glTF allows normalized signed bytes and shorts for rotations, and with KHR_mesh_quantization any
        // byte or short for translations and scales
        bool signed_small = l.component_type == TINYGLTF_COMPONENT_TYPE_BYTE || l.component_type == TINYGLTF_COMPONENT_TYPE_SHORT;
        bool small = signed_small || l.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE ||
                     l.component_type == TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT;
        bool allowed = is_float || (part.components == 4 ? signed_small && l.normalized : quantization_ && small);
        if (l.components != part.components || !allowed)
            fail(std::string(part.name) + " must be a float " + (part.components == 4 ? "VEC4" : "VEC3") +
                 (part.components == 4 ? " or a normalized byte/short one" : quantization_ ? " or (KHR_mesh_quantization) a byte/short one" : "") +
                 " (accessor " + str(a) + ", " + where + ")");
        if (any && l.count != count)
            fail(std::string(part.name) + " count " + str(l.count) + " differs from the other attributes' " + str(count) + " (" +
                 where + ")");
        count = l.count;
        any = true;
        admit(l.count * part.components * sizeof(float));
        *part.into = read_accessor<float>(l, a);
        for (size_t i = 0; i < part.into->size(); i++)
            if (!std::isfinite((*part.into)[i]))
                fail(std::string("non-finite ") + part.name + " at instance " + str(i / part.components) + " (accessor " + str(a) +
                     ", " + where + ")");
    }
    if (!any) fail("no TRANSLATION, ROTATION or SCALE attribute (" + where + ")");
    if (count > kMaxSceneTriangles) fail(str(count) + " instances, more than " + str(kMaxSceneTriangles) + " (" + where + ")");
    for (size_t i = 0; i < set.rotation.size(); i += 4) {
        const float *q = &set.rotation[i];
        double len = std::sqrt(static_cast<double>(q[0]) * q[0] + static_cast<double>(q[1]) * q[1] +
                               static_cast<double>(q[2]) * q[2] + static_cast<double>(q[3]) * q[3]);
        if (!(len > 0)) fail("ROTATION quaternion has zero length at instance " + str(i / 4) + " (" + where + ")");
    }
    int set_index = static_cast<int>(instance_sets_.size());
    admit(count * sizeof(Instance));
    for (uint64_t i = 0; i < count; i++) {
        if (!set.scale.empty() && (set.scale[3 * i] == 0 || set.scale[3 * i + 1] == 0 || set.scale[3 * i + 2] == 0)) {
            if (zero_scale_instances_++ == 0) first_zero_scale_ = "instance " + str(i) + ", " + where;
            continue;
        }
        Instance instance;
        instance.node = node_index;
        instance.mesh = node.mesh;
        instance.set = set_index;
        instance.element = static_cast<uint32_t>(i);
        instances_.push_back(instance);
    }
    instance_sets_.push_back(std::move(set));
}

// The world transform that places an instance (framed once choose_frame has run: the node's is).
Mat4 Loader::instance_world(const Instance &instance) const {
    if (instance.set < 0) return world_[instance.node];
    const InstanceSet &set = instance_sets_[instance.set];
    size_t i = instance.element;
    double t[3] = {0, 0, 0}, q[4] = {0, 0, 0, 1}, s[3] = {1, 1, 1};
    if (!set.translation.empty())
        for (int k = 0; k < 3; k++) t[k] = set.translation[3 * i + k];
    if (!set.rotation.empty()) {
        double len = 0;
        for (int k = 0; k < 4; k++) len += static_cast<double>(set.rotation[4 * i + k]) * set.rotation[4 * i + k];
        len = std::sqrt(len);
        for (int k = 0; k < 4; k++) q[k] = set.rotation[4 * i + k] / len;
    }
    if (!set.scale.empty())
        for (int k = 0; k < 3; k++) s[k] = set.scale[3 * i + k];
    return multiply(world_[instance.node], trs_matrix(t, q, s));
}

// A placement whose transform is singular, far from a unit scale or close to flattening an
// axis, or whose matrix or normal matrix does not fit in float, flattens its mesh: the flat
// path checks every transformed vertex. Embree traces a placement in mesh space through the
// float inverse, and an extreme one (a scale of 1e20, entries of 1e30, one axis scaled by
// 1e-20) hands its intersector a ray it aborts the process on. Bounds, with the Frobenius
// norm f >= the largest singular value: the smallest one is at least |det| / f^2, so
// f^3 / |det| bounds the condition number.
bool placement_instanceable(const Mat4 &w) {
    double det = w.at(0, 0) * (w.at(1, 1) * w.at(2, 2) - w.at(1, 2) * w.at(2, 1)) -
                 w.at(0, 1) * (w.at(1, 0) * w.at(2, 2) - w.at(1, 2) * w.at(2, 0)) +
                 w.at(0, 2) * (w.at(1, 0) * w.at(2, 1) - w.at(1, 1) * w.at(2, 0));
    if (!(det != 0) || !std::isfinite(det) || !std::isfinite(1 / det)) return false;
    double frobenius = 0;
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) frobenius += w.at(r, c) * w.at(r, c);
    frobenius = std::sqrt(frobenius);
    if (!(frobenius >= std::ldexp(1.0, -20) && frobenius <= std::ldexp(1.0, 20)) ||
        !(frobenius * frobenius * frobenius <= std::ldexp(1.0, 20) * std::fabs(det)))
        return false;
    WorldTransform world(w);
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 4; c++)
            if (!std::isfinite(static_cast<float>(world.matrix.at(r, c))) ||
                (c < 3 && !std::isfinite(static_cast<float>(world.normal_matrix[r][c]))))
                return false;
    return true;
}

// A mesh placed by two or more nodes, each with an invertible transform, is stored once and
// placed (instanced); the rest is flattened into world space. Returns per mesh whether it is instanced.
std::vector<char> Loader::choose_instanced_meshes(const std::vector<uint32_t> &uses) const {
    std::vector<char> instanced(model_.meshes.size(), 0);
    for (size_t m = 0; m < uses.size(); m++) instanced[m] = uses[m] >= 2 && !options_.flatten_instances && framed_alone(m);
    for (const Instance &instance : instances_)
        if (instanced[instance.mesh] && !placement_instanceable(instance_world(instance))) instanced[instance.mesh] = 0;
    return instanced;
}

// Whether a mesh's own coordinates are what the scene's framing (choose_frame) would leave alone:
// extent within [2^-20, 2^20] and no farther from its origin than 2^10 extents. A stored mesh
// keeps its own coordinates, which Embree traces in mesh space, so one that the framing would
// rescale or recentre is flattened instead, through the framed world transforms.
bool Loader::framed_alone(size_t mesh) const {
    if (!meshes_[mesh]) return false;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (const DecodedPrimitive &prim : meshes_[mesh]->primitives)
        for (size_t i = 0; prim.triangles && i + 2 < prim.positions.size(); i += 3)
            for (int r = 0; r < 3; r++) {
                lo[r] = std::min(lo[r], static_cast<double>(prim.positions[i + r]));
                hi[r] = std::max(hi[r], static_cast<double>(prim.positions[i + r]));
            }
    double extent = 0, farthest = 0;
    for (int r = 0; r < 3; r++) {
        extent = std::max(extent, hi[r] - lo[r]);
        farthest = std::max(farthest, std::fabs(0.5 * lo[r] + 0.5 * hi[r]));
    }
    return extent >= std::ldexp(1.0, -20) && extent <= std::ldexp(1.0, 20) && std::isfinite(farthest) &&
           farthest <= std::ldexp(1.0, 10) * extent;
}

// After the flat triangles: each instanced mesh (uses > 0) once, in mesh space, then its
// placements, grouped by mesh (pm_instanced_mesh.first_placement), each with the node's world
// transform. Triangle ids follow: the flat triangles', then each placement's in order.
void Loader::place_instanced_meshes(const std::vector<uint32_t> &uses) {
    triangle_ids_ = triangle_material_.size();
    std::vector<std::vector<const Instance *>> placed_by(uses.size());  // one pass over the instances, not one a mesh
    for (const Instance &instance : instances_)
        if (uses[instance.mesh]) placed_by[instance.mesh].push_back(&instance);
    for (size_t m = 0; m < uses.size(); m++) {
        if (!uses[m]) continue;
        const Instance *first = placed_by[m].front();
        pm_instanced_mesh mesh;
        memset(&mesh, 0, sizeof mesh);
        mesh.first_triangle = static_cast<uint32_t>(triangle_material_.size());
        mesh.first_vertex = static_cast<uint32_t>(positions_.size());
        uint64_t degenerate = degenerate_, skipped = skipped_prims_;
        instance_mesh(*first, identity());
        // counted as often as the mesh is placed, as a flattened scene counts them
        degenerate_ += (degenerate_ - degenerate) * (uses[m] - 1);
        skipped_prims_ += (skipped_prims_ - skipped) * (uses[m] - 1);
        mesh.triangle_count = static_cast<uint32_t>(triangle_material_.size()) - mesh.first_triangle;
        mesh.vertex_count = static_cast<uint32_t>(positions_.size()) - mesh.first_vertex;
        mesh.first_placement = static_cast<uint32_t>(placements_.size());
        for (const Instance *instance : placed_by[m]) {
            WorldTransform world(instance_world(*instance));
            pm_placement p;
            memset(&p, 0, sizeof p);
            p.mesh = static_cast<uint32_t>(instanced_meshes_.size());
            p.first_id = static_cast<uint32_t>(triangle_ids_);
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 4; c++) p.object_to_world[4 * r + c] = static_cast<float>(world.matrix.at(r, c));
            for (int r = 0; r < 3; r++)
                for (int c = 0; c < 3; c++) p.normal_matrix[3 * r + c] = static_cast<float>(world.normal_matrix[r][c]);
            p.handedness = world.mirrored ? -1.f : 1.f;
            placements_.push_back(p);
            triangle_ids_ += mesh.triangle_count;
        }
        mesh.placement_count = static_cast<uint32_t>(placements_.size()) - mesh.first_placement;
        instanced_meshes_.push_back(mesh);
    }
}

// ---------------- framing and output: the scene's frame, the load's memory, the pm_scene's arrays

// The file's triangles in world space (before the frame), one after another, for pm_core_bounds.
struct FrameWalk {
    const std::vector<Instance> *instances;
    const std::vector<std::unique_ptr<DecodedMesh>> *meshes;
    const std::vector<Mat4> *world;
    size_t instance = 0, primitive = 0, corner = 0;

    static bool next(void *context, bool restart, double corners[9]) {
        FrameWalk &w = *static_cast<FrameWalk *>(context);
        if (restart) w.instance = w.primitive = w.corner = 0;
        for (; w.instance < w.instances->size(); w.instance++, w.primitive = 0, w.corner = 0) {
            const Instance &instance = (*w.instances)[w.instance];
            const Mat4 &m = (*w.world)[instance.node];
            const std::vector<DecodedPrimitive> &prims = (*w.meshes)[instance.mesh]->primitives;
            for (; w.primitive < prims.size(); w.primitive++, w.corner = 0) {
                const DecodedPrimitive &prim = prims[w.primitive];
                if (!prim.triangles || w.corner + 3 > prim.corners.size()) continue;
                for (int k = 0; k < 3; k++) {
                    const float *p = &prim.positions[3 * static_cast<size_t>(prim.corners[w.corner + k])];
                    for (int r = 0; r < 3; r++)
                        corners[3 * k + r] = m.at(r, 0) * p[0] + m.at(r, 1) * p[1] + m.at(r, 2) * p[2] + m.at(r, 3);
                }
                w.corner += 3;
                return true;
            }
        }
        return false;
    }
};

// The placed triangles' world-space bounds in the file's frame, their number, and the narrowest one's extent.
Loader::PlacedBounds Loader::placed_bounds() const {
    PlacedBounds b;
    double *lo = b.lo, *hi = b.hi;
    for (const Instance &instance : instances_) {
        const Mat4 m = instance_world(instance);
        for (const DecodedPrimitive &prim : meshes_[instance.mesh]->primitives) {
            if (!prim.triangles) continue;
            b.triangles += prim.corners.size() / 3;
            for (size_t c = 0; c + 3 <= prim.corners.size(); c += 3) {
                double tlo[3] = {INFINITY, INFINITY, INFINITY}, thi[3] = {-INFINITY, -INFINITY, -INFINITY};
                for (int k = 0; k < 3; k++) {
                    const float *p = &prim.positions[3 * static_cast<size_t>(prim.corners[c + k])];
                    for (int r = 0; r < 3; r++) {
                        double x = m.at(r, 0) * p[0] + m.at(r, 1) * p[1] + m.at(r, 2) * p[2] + m.at(r, 3);
                        tlo[r] = std::min(tlo[r], x);
                        thi[r] = std::max(thi[r], x);
                    }
                }
                double e = std::max(thi[0] - tlo[0], std::max(thi[1] - tlo[1], thi[2] - tlo[2]));
                if (e > 0) b.smallest = std::min(b.smallest, e);
            }
            for (size_t i = 0; i + 2 < prim.positions.size(); i += 3)
                for (int r = 0; r < 3; r++) {
                    double x = m.at(r, 0) * prim.positions[i] + m.at(r, 1) * prim.positions[i + 1] +
                               m.at(r, 2) * prim.positions[i + 2] + m.at(r, 3);
                    lo[r] = std::min(lo[r], x);
                    hi[r] = std::max(hi[r], x);
                }
        }
    }
    return b;
}

// The renderer works in float and squares lengths (areas, distances, densities), which leave a
// float's range for extents beyond about 1e+-19, and a model far from the origin loses its
// detail to the float spacing there. The image does not change when the whole scene (camera and
// lights included) is moved or scaled, so a scene whose core's extent (pm_core_bounds: small
// strays far away left out) is outside [2^-20, 2^20] is scaled by the power of two that brings it
// near 1 (exact in float), and one whose core lies more than 2^10 extents from the origin is
// moved to it; point and spot intensities scale by the square (the same irradiance), volume
// attenuation by the inverse. Computed in double from the file.
void Loader::choose_frame() {
    PlacedBounds bounds = placed_bounds();
    double *lo = bounds.lo, *hi = bounds.hi;
    const uint64_t triangles = bounds.triangles;
    const double smallest = bounds.smallest;
    // framed by its core (scene_core.c): a small stray far from the bulk neither shrinks the
    // scene to a speck nor moves it; it stays where it is, refused by the accel past the reach
    // Embree can trace
    bool whole = std::isfinite(lo[0]) && std::isfinite(hi[0]) && std::isfinite(lo[1]) && std::isfinite(hi[1]) &&
                 std::isfinite(lo[2]) && std::isfinite(hi[2]);
    if (whole) {
        FrameWalk walk{&instances_, &meshes_, &world_};
        pm_core_source source = {triangles, &walk, FrameWalk::next};
        if (!pm_core_bounds(&source, lo, hi)) throw std::bad_alloc();
    }
    double extent = 0, center[3], farthest = 0;
    for (int r = 0; r < 3; r++) {
        extent = std::max(extent, hi[r] - lo[r]);
        center[r] = 0.5 * lo[r] + 0.5 * hi[r];
        farthest = std::max(farthest, std::fabs(center[r]));
    }
    if (extent > 0 && std::isfinite(extent) && std::isfinite(farthest)) {
        if (extent < std::ldexp(1.0, -20) || extent > std::ldexp(1.0, 20)) frame_scale_ = std::ldexp(1.0, -std::ilogb(extent));
        if (farthest > std::ldexp(1.0, 10) * extent) {
            recentered_ = true;
            std::copy(center, center + 3, frame_center_);
        }
    }
    // Shrinking a scene whose bulk is huge must not shrink its small parts below what float can
    // render (a triangle narrower than 2^-62 has an area under float's smallest normal number): a
    // unit box beside a sphere placed with a scale of 1e38 would become dust and render black.
    if (frame_scale_ < 1 && smallest * frame_scale_ < std::ldexp(1.0, -62))
        fail("the scene's sizes span more than float can render: a triangle " + num(smallest) + " wide beside a bulk " +
             num(extent) + " wide (at most 2^62 apart)");
    if (frame_scale_ != 1 || recentered_) {
        Mat4 frame = identity();
        for (int r = 0; r < 3; r++) {
            frame.m[r * 5] = frame_scale_;
            frame.m[12 + r] = -frame_center_[r] * frame_scale_;
        }
        for (Mat4 &w : world_) w = multiply(frame, w);
    }
    frame_attenuation();
    for (const Placed &p : placed_) {
        WorldTransform world(world_[p.node]);
        if (p.light) add_light(p.index, world, p.node);
        else add_camera(p.index, world, p.node);
    }
}

// Volume attenuation per unit length: divided by the frame's scale, in double before it becomes a float.
void Loader::frame_attenuation() {
    for (size_t i = 0; i < materials_.size(); i++) {
        float sigma[3];
        for (int k = 0; k < 3; k++) {
            double framed = attenuation_[i][k] / frame_scale_;
            if (framed > FLT_MAX) note(material_label(i), "KHR_materials_volume attenuation", num(framed) +
                                       " per unit length (-ln attenuationColor / attenuationDistance) clamped to " +
                                       num(FLT_MAX));
            sigma[k] = static_cast<float>(std::min<double>(framed, FLT_MAX));
        }
        materials_[i].attenuation = v3(sigma[0], sigma[1], sigma[2]);
    }
}

// The scene's totals after instancing (each instanced mesh's triangles counted once), refused past
// the scene limits or 32-bit triangle ids; triangle_ids_ counts every placed triangle.
Loader::SceneTotals Loader::count_scene(const std::vector<char> &instanced) {
    SceneTotals totals;
    std::vector<char> counted(model_.meshes.size(), 0);
    for (const Instance &instance : instances_) {
        const DecodedMesh &mesh = *meshes_[instance.mesh];
        if (instanced[instance.mesh]) {
            totals.placements++;
            triangle_ids_ += mesh.triangles;
            if (counted[instance.mesh]++) continue;  // stored once
        } else {
            triangle_ids_ += mesh.triangles;
        }
        totals.vertices += mesh.vertices;
        totals.triangles += mesh.triangles;
        if (totals.vertices > kMaxSceneVertices || totals.triangles > kMaxSceneTriangles)
            fail("scene too large: more than " + str(kMaxSceneVertices) + " vertices or " + str(kMaxSceneTriangles) +
                 " triangles after instancing");
    }
    if (triangle_ids_ >= UINT32_MAX)
        fail("scene too large: " + str(triangle_ids_) + " placed triangles (a triangle id is 32 bits)");
    return totals;
}

// The scene's arrays and the acceleration structure, estimated before either is allocated.
void Loader::admit_scene_geometry(const SceneTotals &totals) {
    uint64_t per_vertex = 2 * sizeof(vec3) + 2 * sizeof(float) * (uv1_needed_ ? 2 : 1) + (tangents_needed_ ? 4 * sizeof(float) : 0);
    // (Embree's share as the memory forecast counts it: accel.c, pm_accel_forecast_bytes)
    uint64_t accel = totals.triangles * PM_ACCEL_BUILD_BYTES_PER_TRIANGLE + totals.vertices * PM_ACCEL_BYTES_PER_VERTEX +
                     totals.placements * PM_ACCEL_BYTES_PER_PLACEMENT;
    uint64_t bytes = totals.vertices * per_vertex + totals.triangles * 4 * sizeof(uint32_t) +
                     totals.placements * sizeof(pm_placement) + accel +
                     placed_.size() * (sizeof(pm_light) + sizeof(float) + sizeof(pm_camera));  // lights, their power table, cameras
    const uint64_t mark = pm_memory_failure_mark();
    if (!pm_memory_admit(bytes, "scene geometry and its acceleration structure"))
        fail("out of memory (" + std::string(pm_memory_failure_since_or(mark, "scene geometry and its acceleration structure")) +
             "): " + str(totals.triangles) +
             " triangles after instancing");
    // the acceleration structure's share was a forecast: Embree's allocations are admitted as they happen
    pm_memory_release(accel);
    admitted_.bytes += bytes - accel;
}

template <class T>
T *malloc_copy(const std::vector<T> &v) {
    if (v.empty()) return nullptr;
    T *p = static_cast<T *>(pm_malloc(v.size() * sizeof(T), "scene arrays"));
    if (!p) throw std::bad_alloc();
    memcpy(p, v.data(), v.size() * sizeof(T));
    return p;
}

template <class T>
uint64_t vector_bytes(const std::vector<T> &v) { return v.capacity() * sizeof(T); }

uint64_t Loader::model_bytes() const {
    uint64_t bytes = 0;
    for (const tinygltf::Buffer &b : model_.buffers) bytes += vector_bytes(b.data);
    for (const tinygltf::Image &i : model_.images) bytes += vector_bytes(i.image);
    return bytes;
}

uint64_t Loader::decoded_bytes() const {
    uint64_t bytes = 0;
    for (const std::unique_ptr<DecodedMesh> &m : meshes_)
        if (m)
            for (const DecodedPrimitive &p : m->primitives)
                bytes += vector_bytes(p.positions) + vector_bytes(p.normals) + vector_bytes(p.uvs) + vector_bytes(p.uvs1) +
                         vector_bytes(p.tangents) + vector_bytes(p.corners);
    for (const InstanceSet &set : instance_sets_)
        bytes += vector_bytes(set.translation) + vector_bytes(set.rotation) + vector_bytes(set.scale);
    for (const pm_texture &t : textures_.items) bytes += 4ull * static_cast<uint64_t>(t.width) * static_cast<uint64_t>(t.height);
    return bytes;
}

uint64_t Loader::output_bytes() const {
    return vector_bytes(positions_) + vector_bytes(normals_) + vector_bytes(uvs_) + vector_bytes(uvs1_) +
           vector_bytes(tangents_) + vector_bytes(indices_) + vector_bytes(triangle_material_) + vector_bytes(materials_) +
           vector_bytes(placements_) + vector_bytes(instanced_meshes_) + vector_bytes(instances_);
}

void Loader::emit(pm_scene *out) {
    forecast_phase(file_bytes_ + model_bytes() + decoded_bytes() + 2 * output_bytes());
    pm_scene s;
    memset(&s, 0, sizeof s);
    try {
        s.positions = malloc_copy(positions_);
        s.normals = malloc_copy(normals_);
        if (any_uv_) s.uvs = malloc_copy(uvs_);
        if (any_uv1_) s.uvs1 = malloc_copy(uvs1_);
        if (tangents_needed_) s.tangents = malloc_copy(tangents_);
        s.indices = malloc_copy(indices_);
        s.triangle_material = malloc_copy(triangle_material_);
        s.materials = malloc_copy(materials_);
        s.lights = malloc_copy(lights_);
        s.cameras = malloc_copy(cameras_);
        s.textures = malloc_copy(textures_.items);
        s.instanced_meshes = malloc_copy(instanced_meshes_);
        s.placements = malloc_copy(placements_);
        s.variant_names = malloc_copy(variant_names_);
    } catch (...) {
        pm_scene_free(&s);
        throw;
    }
    s.texture_count = static_cast<uint32_t>(textures_.items.size());
    textures_.items.clear();  // the scene owns the texels now
    s.vertex_count = static_cast<uint32_t>(positions_.size());
    s.triangle_count = static_cast<uint32_t>(triangle_material_.size());
    s.material_count = static_cast<uint32_t>(materials_.size());
    s.light_count = static_cast<uint32_t>(lights_.size());
    s.camera_count = static_cast<uint32_t>(cameras_.size());
    s.instanced_mesh_count = static_cast<uint32_t>(instanced_meshes_.size());
    s.placement_count = static_cast<uint32_t>(placements_.size());
    s.triangle_id_count = static_cast<uint32_t>(triangle_ids_);
    s.variant_count = variant_count_;
    s.memory_admitted = admitted_.bytes;
    admitted_.bytes = 0;
    *out = s;
}

// ---------------- the load: every stage in order, then its closing checks and warnings

void Loader::load(pm_scene *out) {
    std::vector<unsigned char> file = read_model_file();
    file_bytes_ = file.capacity();
    split_container(file);
    model_from_json();

    traverse_default_scene();
    apply_variant();
    convert_materials();  // first: whether any texture reads TEXCOORD_1 decides what the meshes keep
    meshes_.resize(model_.meshes.size());
    std::vector<uint32_t> uses = decode_placed_meshes();
    choose_frame();  // the placements' matrices below are the framed ones
    std::vector<char> instanced = choose_instanced_meshes(uses);
    SceneTotals totals = count_scene(instanced);
    for (size_t m = 0; m < uses.size(); m++)
        if (!instanced[m]) uses[m] = 0;
    admit_scene_geometry(totals);
    if (default_material_used_) add_default_material();
    positions_.reserve(totals.vertices);
    normals_.reserve(totals.vertices);
    uvs_.reserve(2 * totals.vertices);
    if (uv1_needed_) uvs1_.reserve(2 * totals.vertices);
    if (tangents_needed_) tangents_.reserve(4 * totals.vertices);
    indices_.reserve(3 * totals.triangles);
    triangle_material_.reserve(totals.triangles);
    for (const Instance &instance : instances_)
        if (!uses[instance.mesh]) instance_mesh(instance, instance_world(instance));
    place_instanced_meshes(uses);
    check_something_to_render();
    warn_load_counts();
    finish_notes();
    emit(out);
}

// A load without a triangle to render fails with the reason.
void Loader::check_something_to_render() const {
    if (triangle_material_.empty() && degenerate_)
        fail("nothing to render: all " + str(degenerate_) +
             " triangle(s) of the default scene are degenerate (zero area, or not representable after the transforms)");
    if (triangle_material_.empty() && skipped_prims_)
        fail("nothing to render: the default scene has only points/lines primitives (" + str(skipped_prims_) +
             " skipped; only triangles render)");
    if (triangle_material_.empty()) fail("nothing to render (no triangles in the default scene)");
}

// One warning per kind of input the load left out or replaced, with its count and first instance.
void Loader::warn_load_counts() {
    if (degenerate_) warn("skipped " + str(degenerate_) + " degenerate triangle(s) (zero area or non-finite normal)");
    if (nonfinite_uvs_)
        warn(str(nonfinite_uvs_) + " non-finite texture coordinate(s) read as 0 (first: " + first_nonfinite_uv_ + ")");
    if (skipped_prims_) warn("skipped " + str(skipped_prims_) + " points/lines primitive(s) (only triangles render)");
    if (zero_scale_instances_)
        warn("left out " + str(zero_scale_instances_) + " EXT_mesh_gpu_instancing instance(s) with a zero SCALE component (first: " +
             first_zero_scale_ + "): they place nothing");
    if (collapsed_normals_)
        warn(str(collapsed_normals_) + " NORMAL value(s) lost their direction to their node's transform (first: " +
             first_collapsed_ + "): their triangles get flat normals, as without NORMAL");
}

}  // namespace

namespace {

// What both entries share: runs the loader, prints warnings unless quiet, turns failures into err.
bool run_loader(const char *path, const unsigned char *data, size_t size, const pm_load_options *options, bool quiet,
                pm_scene *out, pm_load_report *report, char *err, size_t err_size) {
    auto start = std::chrono::steady_clock::now();
    memset(out, 0, sizeof *out);
    pm_load_report local_report;
    if (!report) report = &local_report;
    memset(report, 0, sizeof *report);
    if (err && err_size) err[0] = '\0';
    std::string message;
    const uint64_t mark = pm_memory_failure_mark();  // what this load meets, never an older failure
    try {
        std::unique_ptr<Loader> made(data ? new Loader(path ? path : "", data, size) : new Loader(path ? path : ""));
        Loader &loader = *made;
        if (options) loader.set_options(*options);
        try {
            loader.load(out);
        } catch (const LoadError &e) {
            message = e.message;
        }
        report->json_parses = loader.json_parses();
        report->json_seconds = loader.json_seconds();
        if (message.empty()) {  // warnings are printed only for a scene that loaded
            report->warnings = static_cast<uint32_t>(loader.warnings().size());
            report->skipped_degenerate = loader.skipped_degenerate();
            report->skipped_primitives = loader.skipped_primitives();
            report->ignored_inputs = loader.ignored_inputs();
            report->occlusion_textures_ignored = loader.occlusion_textures_ignored();
            report->unit_scale = loader.unit_scale();
            report->recentered = loader.recentered();
            report->peak_bytes = loader.forecast_peak();
            for (const std::string &w : loader.warnings())
                if (!quiet) fprintf(stderr, "pmview: warning: %s: %s\n", path, w.c_str());
        }
    } catch (const std::bad_alloc &) {
        message = "out of memory";
        if (pm_memory_failure_since(mark)) message += " (" + std::string(pm_memory_failure_since(mark)) + ")";
    } catch (const std::exception &e) {
        message = "unexpected error: " + one_line(e.what());
    } catch (...) {
        message = "unexpected error";
    }
    report->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (message.empty()) return true;
    memset(out, 0, sizeof *out);
    if (err && err_size) {
        std::string line = printable(path ? path : "(null)", 400) + ": " + one_line(message, 600);
        snprintf(err, err_size, "%s", line.c_str());
    }
    return false;
}

}  // namespace

extern "C" bool pm_load_gltf(const char *path, bool quiet, pm_scene *out, pm_load_report *report, char *err,
                             size_t err_size) {
    return run_loader(path, nullptr, 0, nullptr, quiet, out, report, err, err_size);
}

extern "C" bool pm_load_gltf_with(const char *path, const pm_load_options *options, bool quiet, pm_scene *out,
                                  pm_load_report *report, char *err, size_t err_size) {
    return run_loader(path, nullptr, 0, options, quiet, out, report, err, err_size);
}

extern "C" bool pm_load_gltf_memory(const void *data, size_t size, const char *name, bool quiet, pm_scene *out,
                                    pm_load_report *report, char *err, size_t err_size) {
    static const unsigned char nothing = 0;  // a non-null pointer for empty input, so it is not read as a path
    const unsigned char *bytes = data && size ? static_cast<const unsigned char *>(data) : &nothing;
    return run_loader(name ? name : "(memory)", bytes, data ? size : 0, nullptr, quiet, out, report, err, err_size);
}

extern "C" bool pm_load_gltf_memory_with(const void *data, size_t size, const char *name, const pm_load_options *options,
                                         bool quiet, pm_scene *out, pm_load_report *report, char *err, size_t err_size) {
    static const unsigned char nothing = 0;
    const unsigned char *bytes = data && size ? static_cast<const unsigned char *>(data) : &nothing;
    return run_loader(name ? name : "(memory)", bytes, data ? size : 0, options, quiet, out, report, err, err_size);
}
