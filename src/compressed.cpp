/* compressed.cpp: EXT_meshopt_compression and KHR_draco_mesh_compression decoding through Debian's libmeshoptimizer and libdraco (see compressed.h). */
#include "compressed.h"
extern "C" {
#include "memory.h"
}

#include <draco/compression/config/compression_shared.h>
#include <draco/compression/decode.h>
#include <draco/compression/point_cloud/point_cloud_decoder.h>
#include <draco/core/varint_decoding.h>
#include <draco/mesh/mesh.h>
#include <draco/metadata/geometry_metadata.h>
#include <draco/metadata/metadata_decoder.h>
#include <malloc.h>
#include <meshoptimizer.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

namespace {

void set_error(char *err, size_t err_size, const std::string &message) {
    if (err && err_size) snprintf(err, err_size, "%s", message.c_str());
}

size_t component_bytes(int type) {
    switch (type) {
    case 5120: case 5121: return 1;
    case 5122: case 5123: return 2;
    case 5125: case 5126: return 4;
    default: return 0;
    }
}

// One value into a glTF component: floats as they are, normalized integers as glTF reads them
// back (c / max, so round(v * max)), other integers rounded; false when it does not fit.
template <class T>
bool store_integer(double v, bool normalized, unsigned char *out) {
    const double lo = static_cast<double>(std::numeric_limits<T>::min()),
                 hi = static_cast<double>(std::numeric_limits<T>::max());
    if (normalized) v *= hi;
    v = std::nearbyint(v);
    if (!(v >= lo - (normalized ? 1 : 0) && v <= hi)) return false;
    T t = static_cast<T>(std::max(v, lo));
    memcpy(out, &t, sizeof t);
    return true;
}

bool store_component(double v, int type, bool normalized, unsigned char *out) {
    switch (type) {
    case 5120: return store_integer<int8_t>(v, normalized, out);
    case 5121: return store_integer<uint8_t>(v, normalized, out);
    case 5122: return store_integer<int16_t>(v, normalized, out);
    case 5123: return store_integer<uint16_t>(v, normalized, out);
    case 5125: return store_integer<uint32_t>(v, false, out);
    default: {
        float f = static_cast<float>(v);
        memcpy(out, &f, sizeof f);
        return true;
    }
    }
}

}  // namespace

struct pm_draco_mesh {
    std::unique_ptr<draco::Mesh> mesh;
    uint64_t admitted = 0; // bytes admitted for the decode, given back with the mesh
    ~pm_draco_mesh() { pm_memory_release(admitted); }
};

extern "C" int pm_meshopt_mode(const char *name) {
    if (!strcmp(name, "ATTRIBUTES")) return PM_MESHOPT_ATTRIBUTES;
    if (!strcmp(name, "TRIANGLES")) return PM_MESHOPT_TRIANGLES;
    if (!strcmp(name, "INDICES")) return PM_MESHOPT_INDICES;
    return PM_MESHOPT_MODE_UNKNOWN;
}

extern "C" int pm_meshopt_filter(const char *name) {
    if (!strcmp(name, "NONE")) return PM_MESHOPT_FILTER_NONE;
    if (!strcmp(name, "OCTAHEDRAL")) return PM_MESHOPT_FILTER_OCTAHEDRAL;
    if (!strcmp(name, "QUATERNION")) return PM_MESHOPT_FILTER_QUATERNION;
    if (!strcmp(name, "EXPONENTIAL")) return PM_MESHOPT_FILTER_EXPONENTIAL;
    return PM_MESHOPT_FILTER_UNKNOWN;
}

extern "C" bool pm_meshopt_decode(void *dst, size_t count, size_t stride, int mode, int filter, const void *src,
                                  size_t src_size, char *err, size_t err_size) {
    const std::string at = " (count " + std::to_string(count) + ", byteStride " + std::to_string(stride) + ")";
    if (count == 0) return set_error(err, err_size, "count 0" + at), false;
    if (mode == PM_MESHOPT_ATTRIBUTES && (stride == 0 || stride > 256 || stride % 4 != 0))
        return set_error(err, err_size, "ATTRIBUTES need a byteStride that is a multiple of 4 in [4, 256]" + at), false;
    if ((mode == PM_MESHOPT_TRIANGLES || mode == PM_MESHOPT_INDICES) && stride != 2 && stride != 4)
        return set_error(err, err_size, "TRIANGLES and INDICES need a byteStride of 2 or 4" + at), false;
    if (mode == PM_MESHOPT_TRIANGLES && count % 3 != 0)
        return set_error(err, err_size, "TRIANGLES need a count that is a multiple of 3" + at), false;
    if (mode != PM_MESHOPT_ATTRIBUTES && mode != PM_MESHOPT_TRIANGLES && mode != PM_MESHOPT_INDICES)
        return set_error(err, err_size, "unknown mode"), false;
    if (filter != PM_MESHOPT_FILTER_NONE && mode != PM_MESHOPT_ATTRIBUTES)
        return set_error(err, err_size, "a filter other than NONE needs mode ATTRIBUTES"), false;
    if (filter == PM_MESHOPT_FILTER_OCTAHEDRAL && stride != 4 && stride != 8)
        return set_error(err, err_size, "OCTAHEDRAL needs a byteStride of 4 or 8" + at), false;
    if (filter == PM_MESHOPT_FILTER_QUATERNION && stride != 8)
        return set_error(err, err_size, "QUATERNION needs a byteStride of 8" + at), false;
    if (filter < PM_MESHOPT_FILTER_NONE || filter >= PM_MESHOPT_FILTER_UNKNOWN)
        return set_error(err, err_size, "unknown filter"), false;
    if (count > SIZE_MAX / stride || count * stride / PM_MESHOPT_MAX_RATIO > src_size)
        return set_error(err, err_size, "decoded size " + std::to_string(count) + " x " + std::to_string(stride) +
                                            " is over " + std::to_string(PM_MESHOPT_MAX_RATIO) +
                                            " times the " + std::to_string(src_size) + "-byte stream"),
               false;
    const unsigned char *bytes = static_cast<const unsigned char *>(src);
    int rc = mode == PM_MESHOPT_ATTRIBUTES  ? meshopt_decodeVertexBuffer(dst, count, stride, bytes, src_size)
             : mode == PM_MESHOPT_TRIANGLES ? meshopt_decodeIndexBuffer(dst, count, stride, bytes, src_size)
                                            : meshopt_decodeIndexSequence(dst, count, stride, bytes, src_size);
    if (rc != 0)
        return set_error(err, err_size, std::string("corrupt or truncated ") +
                                            (mode == PM_MESHOPT_ATTRIBUTES ? "ATTRIBUTES" :
                                             mode == PM_MESHOPT_TRIANGLES  ? "TRIANGLES" : "INDICES") +
                                            " stream of " + std::to_string(src_size) + " bytes" + at +
                                            ": meshoptimizer error " + std::to_string(rc)),
               false;
    if (filter == PM_MESHOPT_FILTER_OCTAHEDRAL) meshopt_decodeFilterOct(dst, count, stride);
    if (filter == PM_MESHOPT_FILTER_QUATERNION) meshopt_decodeFilterQuat(dst, count, stride);
    if (filter == PM_MESHOPT_FILTER_EXPONENTIAL) meshopt_decodeFilterExp(dst, count, stride);
    return true;
}

namespace {

// libdraco allocates with operator new and takes no allocator, and it trusts some counts of a
// corrupt stream (a 10 KB stream asked for 220 MB). Its decode thread therefore runs under a
// budget: the process's operator new (replaced below) counts what that thread holds and throws
// std::bad_alloc past the budget, which was admitted under --max-memory before the decode began.
// Every other thread allocates as the C++ library would.
struct DracoBudget {
    uint64_t limit = 0, used = 0;
    bool exceeded = false;
    std::atomic<bool> abandoned{false}; // the caller stopped waiting: the decode is to end
};
thread_local DracoBudget *thread_budget = nullptr;

void *counted_new(std::size_t size) {
    DracoBudget *b = thread_budget;
    if (b && (b->abandoned.load(std::memory_order_relaxed) || size > b->limit || b->used > b->limit - size)) {
        b->exceeded = !b->abandoned.load(std::memory_order_relaxed);
        throw std::bad_alloc();
    }
    void *p = std::malloc(size ? size : 1);
    if (!p) throw std::bad_alloc();
    if (b) b->used += malloc_usable_size(p);
    return p;
}

void counted_delete(void *p) noexcept {
    DracoBudget *b = thread_budget;
    if (p && b) {
        uint64_t n = malloc_usable_size(p);
        b->used = n < b->used ? b->used - n : 0; // a block allocated by another thread may be freed here
    }
    std::free(p);
}

}  // namespace

void *operator new(std::size_t size) { return counted_new(size); }
void *operator new[](std::size_t size) { return counted_new(size); }
void *operator new(std::size_t size, const std::nothrow_t &) noexcept {
    try { return counted_new(size); } catch (...) { return nullptr; }
}
void *operator new[](std::size_t size, const std::nothrow_t &) noexcept {
    try { return counted_new(size); } catch (...) { return nullptr; }
}
void operator delete(void *p) noexcept { counted_delete(p); }
void operator delete[](void *p) noexcept { counted_delete(p); }
void operator delete(void *p, std::size_t) noexcept { counted_delete(p); }
void operator delete[](void *p, std::size_t) noexcept { counted_delete(p); }
void operator delete(void *p, const std::nothrow_t &) noexcept { counted_delete(p); }
void operator delete[](void *p, const std::nothrow_t &) noexcept { counted_delete(p); }

namespace {

// What a stream says of itself before its payload: the header, the metadata when the flags say
// there is some, then the connectivity's counts (libdraco's MeshSequentialDecoder and
// MeshEdgebreakerDecoderImpl read them in this order; counts are varints from bitstream 2.0 on,
// except the sequential coder's, from 2.2).
struct DracoCounts {
    bool ok = false;
    std::string error;
    uint64_t vertices = 0, faces = 0;
};

DracoCounts draco_counts(const char *src, size_t size) {
    DracoCounts c;
    draco::DecoderBuffer buffer;
    buffer.Init(src, size);
    draco::DracoHeader header;
    if (!draco::PointCloudDecoder::DecodeHeader(&buffer, &header).ok()) {
        c.error = "not a Draco stream (no DRACO header)";
        return c;
    }
    if (header.encoder_type != draco::TRIANGULAR_MESH) {
        c.error = "the Draco stream holds a point cloud, not a triangle mesh";
        return c;
    }
    const uint16_t version = DRACO_BITSTREAM_VERSION(header.version_major, header.version_minor);
    buffer.set_bitstream_version(version);
    if (header.flags & METADATA_FLAG_MASK) {
        draco::MetadataDecoder metadata_decoder;
        draco::GeometryMetadata metadata;
        if (!metadata_decoder.DecodeGeometryMetadata(&buffer, &metadata)) {
            c.error = "corrupt Draco stream: its metadata cannot be read";
            return c;
        }
    }
    uint32_t vertices = 0, faces = 0;
    bool read = false;
    if (header.encoder_method == draco::MESH_SEQUENTIAL_ENCODING) {
        if (version < DRACO_BITSTREAM_VERSION(2, 2)) read = buffer.Decode(&faces) && buffer.Decode(&vertices);
        else read = draco::DecodeVarint(&faces, &buffer) && draco::DecodeVarint(&vertices, &buffer);
    } else if (header.encoder_method == draco::MESH_EDGEBREAKER_ENCODING) {
        uint8_t traversal = 0;
        uint32_t new_vertices = 0;
        const bool varints = version >= DRACO_BITSTREAM_VERSION(2, 0);
        read = buffer.Decode(&traversal);
        if (read && version < DRACO_BITSTREAM_VERSION(2, 2))
            read = varints ? draco::DecodeVarint(&new_vertices, &buffer) : buffer.Decode(&new_vertices);
        if (read) read = varints ? draco::DecodeVarint(&vertices, &buffer) : buffer.Decode(&vertices);
        if (read) read = varints ? draco::DecodeVarint(&faces, &buffer) : buffer.Decode(&faces);
        vertices += new_vertices;
    } else {
        c.error = "the Draco stream names an unknown mesh encoding (" + std::to_string(header.encoder_method) + ")";
        return c;
    }
    if (!read) {
        c.error = "corrupt or truncated Draco stream: its vertex and face counts cannot be read";
        return c;
    }
    c.ok = true;
    c.vertices = vertices;
    c.faces = faces;
    return c;
}

// One Draco decode, shared by the thread that runs it and the caller that waits for it: a caller
// that stops waiting marks it abandoned (the thread's next allocation fails, which ends the decode)
// and leaves the job to the thread, which frees it and gives its admitted bytes back when it ends.
struct DracoJob {
    std::mutex lock;
    std::condition_variable finished_signal;
    bool finished = false;
    std::vector<char> bytes;
    std::unique_ptr<draco::Mesh> mesh;
    std::string error;
    DracoBudget budget;
    uint64_t admitted = 0;
    ~DracoJob() { pm_memory_release(admitted); }
};

void decode_draco(const std::shared_ptr<DracoJob> &job) {
    std::unique_ptr<draco::Mesh> mesh;
    std::string error;
    thread_budget = &job->budget;
    try {
        draco::DecoderBuffer buffer;
        buffer.Init(job->bytes.data(), job->bytes.size());
        auto type = draco::Decoder::GetEncodedGeometryType(&buffer);
        if (!type.ok()) {
            error = "not a Draco stream: " + type.status().error_msg_string();
        } else if (type.value() != draco::TRIANGULAR_MESH) {
            error = "the Draco stream holds a point cloud, not a triangle mesh";
        } else {
            draco::Decoder decoder;
            auto decoded = decoder.DecodeMeshFromBuffer(&buffer);
            if (!decoded.ok()) error = "corrupt Draco stream: " + decoded.status().error_msg_string();
            else mesh = std::move(decoded).value();
            if (error.empty() && !mesh) error = "corrupt Draco stream: no mesh";
        }
    } catch (const std::bad_alloc &) {
        error = "out of memory decoding the Draco stream";
    } catch (const std::exception &e) {
        error = std::string("corrupt Draco stream: ") + e.what();
    }
    // libdraco may turn a failed allocation into a status of its own: the budget says what happened
    if (job->budget.exceeded) {
        mesh.reset();
        char mib[32];
        snprintf(mib, sizeof mib, "%.1f", static_cast<double>(job->budget.limit) / (1 << 20));
        error = std::string("the Draco stream asks for more than the ") + mib +
                " MiB its counts and size allow (a corrupt count): refused";
    }
    thread_budget = nullptr;
    std::lock_guard<std::mutex> hold(job->lock);
    job->mesh = std::move(mesh);
    job->error = error;
    job->finished = true;
    job->finished_signal.notify_all();
}

}  // namespace

// libdraco 1.5.5 trusts some counts in a stream (texture coordinates' orientation bits): a corrupt
// one costs up to 2^31 steps (about 30 s and 300 MB) before the stream is refused. The decode runs
// on a thread of its own under the memory budget its counts forecast (such a count asks for far
// more and fails at once) and with a time budget far above a valid stream's decoding time; past
// that the stream is refused, and the thread's next allocation fails, which ends its decode.
static std::atomic<uint64_t> draco_decodes{0};
extern "C" uint64_t pm_draco_decodes(void) { return draco_decodes.load(); }

extern "C" uint64_t pm_draco_forecast_bytes(uint64_t vertices, uint64_t faces, uint64_t stream_bytes) {
    return PM_DRACO_BASE_BYTES + vertices * PM_DRACO_BYTES_PER_VERTEX + faces * PM_DRACO_BYTES_PER_FACE +
           stream_bytes * PM_DRACO_BYTES_PER_STREAM_BYTE;
}

extern "C" pm_draco_mesh *pm_draco_decode(const void *src, size_t size, char *err, size_t err_size) {
    draco_decodes++;
    const double budget = PM_DRACO_SECONDS + static_cast<double>(size) * PM_DRACO_SECONDS_PER_BYTE;
    try {
        DracoCounts counts = draco_counts(static_cast<const char *>(src), size);
        if (!counts.ok) return set_error(err, err_size, counts.error), nullptr;
        // the stream's own counts bound what a valid decode needs: admitted before it starts
        const uint64_t forecast = pm_draco_forecast_bytes(counts.vertices, counts.faces, size);
        const uint64_t mark = pm_memory_failure_mark();
        if (!pm_memory_admit(forecast, "the Draco decoder")) {
            const char *why = pm_memory_failure_since(mark);
            return set_error(err, err_size, "a Draco stream of " + std::to_string(counts.vertices) + " vertices and " +
                                                std::to_string(counts.faces) + " triangles: out of memory (" +
                                                (why ? why : "the Draco decoder") + ")"),
                   nullptr;
        }
        auto job = std::make_shared<DracoJob>();
        job->admitted = forecast;
        job->budget.limit = forecast;
        job->bytes.assign(static_cast<const char *>(src), static_cast<const char *>(src) + size);
        std::thread worker(decode_draco, job);
        std::unique_lock<std::mutex> hold(job->lock);
        bool finished = job->finished_signal.wait_for(hold, std::chrono::duration<double>(budget),
                                                      [&] { return job->finished; });
        hold.unlock();
        if (!finished) {
            job->budget.abandoned = true;
            worker.detach();
            char seconds[32];
            snprintf(seconds, sizeof seconds, "%.3g", budget);
            return set_error(err, err_size, std::string("the Draco stream is still decoding after ") + seconds +
                                                " s (a corrupt count): refused"),
                   nullptr;
        }
        worker.join();
        if (!job->mesh) return set_error(err, err_size, job->error), nullptr;
        std::unique_ptr<pm_draco_mesh> out(new pm_draco_mesh);
        out->mesh = std::move(job->mesh);
        out->admitted = forecast; // the decoded mesh holds its share until pm_draco_free
        job->admitted = 0;
        return out.release();
    } catch (const std::bad_alloc &) {
        set_error(err, err_size, "out of memory decoding the Draco stream");
    } catch (const std::system_error &e) {
        set_error(err, err_size, std::string("cannot start the Draco decoder's thread: ") + e.what());
    }
    return nullptr;
}

extern "C" void pm_draco_free(pm_draco_mesh *mesh) { delete mesh; }

extern "C" uint64_t pm_draco_points(const pm_draco_mesh *mesh) { return mesh->mesh->num_points(); }

extern "C" uint64_t pm_draco_triangles(const pm_draco_mesh *mesh) { return mesh->mesh->num_faces(); }

extern "C" bool pm_draco_attribute(const pm_draco_mesh *mesh, uint32_t unique_id, int component_type, int components,
                                   bool normalized, void *dst, char *err, size_t err_size) {
    const draco::PointAttribute *a = mesh->mesh->GetAttributeByUniqueId(unique_id);
    const std::string id = "Draco attribute " + std::to_string(unique_id);
    if (!a) return set_error(err, err_size, id + " is not in the stream"), false;
    if (a->num_components() != components || components < 1 || components > 16)
        return set_error(err, err_size, id + " has " + std::to_string(a->num_components()) +
                                            " components where the accessor has " + std::to_string(components)),
               false;
    const size_t csize = component_bytes(component_type);
    if (csize == 0) return set_error(err, err_size, "componentType " + std::to_string(component_type)), false;
    unsigned char *out = static_cast<unsigned char *>(dst);
    double value[16];
    const uint64_t points = mesh->mesh->num_points();
    for (uint64_t p = 0; p < points; p++) {
        draco::AttributeValueIndex v = a->mapped_index(draco::PointIndex(static_cast<uint32_t>(p)));
        if (v.value() >= a->size() || !a->ConvertValue<double>(v, static_cast<int8_t>(components), value))
            return set_error(err, err_size, id + ": no value for point " + std::to_string(p)), false;
        for (int c = 0; c < components; c++, out += csize)
            if (!std::isfinite(value[c]) || !store_component(value[c], component_type, normalized, out))
                return set_error(err, err_size, id + ": value " + std::to_string(value[c]) + " at point " +
                                                    std::to_string(p) + " does not fit componentType " +
                                                    std::to_string(component_type)),
                       false;
    }
    return true;
}

extern "C" bool pm_draco_indices(const pm_draco_mesh *mesh, int component_type, void *dst, char *err, size_t err_size) {
    const size_t csize = component_bytes(component_type);
    if (component_type != 5121 && component_type != 5123 && component_type != 5125)
        return set_error(err, err_size, "indices must be UNSIGNED_BYTE/SHORT/INT"), false;
    const uint64_t limit = csize == 4 ? UINT32_MAX : (1ull << (8 * csize)) - 1;
    unsigned char *out = static_cast<unsigned char *>(dst);
    for (uint32_t f = 0; f < mesh->mesh->num_faces(); f++) {
        const draco::Mesh::Face &face = mesh->mesh->face(draco::FaceIndex(f));
        for (int k = 0; k < 3; k++, out += csize) {
            uint32_t i = face[k].value();
            // an index past the points is left to the loader's index check, as for any accessor
            if (i > limit)
                return set_error(err, err_size, "decoded index " + std::to_string(i) + " of triangle " + std::to_string(f) +
                                                    " does not fit componentType " + std::to_string(component_type)),
                       false;
            if (csize == 1) out[0] = static_cast<unsigned char>(i);
            else if (csize == 2) { uint16_t s = static_cast<uint16_t>(i); memcpy(out, &s, 2); }
            else memcpy(out, &i, 4);
        }
    }
    return true;
}
