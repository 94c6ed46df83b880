#!/usr/bin/env python3
"""fuzz_seeds.py: turns the glTF files under the given folders into self-contained fuzz seeds (one file each) in OUT; with --inputs, seeds for the file-inputs target instead.

The fuzz target loads from memory, so a .gltf's external buffers and images are embedded as
data: URIs; an image file above IMAGE_LIMIT bytes is replaced by a 2x2 PNG (the mutator gains
nothing from megabytes of pixels, and every execution would decode them). A .glb is copied as
it is. Seeds above SEED_LIMIT are left out: each execution of one costs seconds under
ASan (run-fuzz.sh gives libFuzzer the same -max_len). Missing folders are skipped. Standard library only.

    python3 tools/fuzz_seeds.py OUT DIR...
    python3 tools/fuzz_seeds.py --inputs OUT DIR...
    python3 tools/fuzz_seeds.py --compressed OUT DIR...

With --inputs (tests/fuzz/fuzz_inputs_entry.h: the first byte picks the entry): every .exr under
the folders as a sky map (0) and as a reference (2), small Radiance .hdr files written here, flat
and run-length encoded (1), and a few films for the writers (3).

With --compressed (tests/fuzz/fuzz_compressed_entry.h): every Draco stream (0) and meshopt
bufferView (1, with its mode, filter, stride and count) of the .glb files under the folders.
"""
import base64
import json
import os
import struct
import sys
import zlib

IMAGE_LIMIT = 64 * 1024
SEED_LIMIT = 160 * 1024


def tiny_png():
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))
    rows = b"".join(b"\x00" + bytes([200, 60, 30, 90, 200, 30]) for _ in range(2))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 2, 2, 8, 2, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))


def data_uri(mime, data):
    return "data:%s;base64,%s" % (mime, base64.b64encode(data).decode("ascii"))


def embedded_gltf(path):
    with open(path, "rb") as f:
        doc = json.load(f)
    folder = os.path.dirname(path)
    for buf in doc.get("buffers", []) if isinstance(doc, dict) else []:
        uri = buf.get("uri") if isinstance(buf, dict) else None
        if isinstance(uri, str) and not uri.startswith("data:"):
            try:
                with open(os.path.join(folder, uri), "rb") as f:
                    buf["uri"] = data_uri("application/octet-stream", f.read())
            except OSError:
                pass  # an invalid-corpus file naming a missing buffer stays as it is
    for img in doc.get("images", []) if isinstance(doc, dict) else []:
        uri = img.get("uri") if isinstance(img, dict) else None
        if isinstance(uri, str) and not uri.startswith("data:"):
            file = os.path.join(folder, uri)
            if os.path.isfile(file) and os.path.getsize(file) <= IMAGE_LIMIT:
                mime = "image/jpeg" if uri.lower().endswith((".jpg", ".jpeg")) else "image/png"
                with open(file, "rb") as f:
                    img["uri"] = data_uri(mime, f.read())
            elif os.path.isfile(file):
                img["uri"] = data_uri("image/png", tiny_png())
    return json.dumps(doc, separators=(",", ":")).encode("utf-8")


def rgbe(r, g, b):
    m = max(r, g, b)
    if m < 1e-32:
        return bytes(4)
    e = 0
    while m >= 1.0:
        m /= 2.0
        e += 1
    while m < 0.5:
        m *= 2.0
        e -= 1
    scale = 256.0 / (2.0 ** e)
    return bytes([min(255, int(r * scale)), min(255, int(g * scale)), min(255, int(b * scale)), e + 128])


def hdr_file(width, height, run_length):
    """A small Radiance picture: a gradient, its rows flat RGBE or in the new run-length form."""
    out = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (height, width)
    for y in range(height):
        pixels = [rgbe(0.1 + x / width, 0.5, 1.0 - y / height) for x in range(width)]
        if not run_length:
            out += b"".join(pixels)
            continue
        out += bytes([2, 2, width >> 8, width & 255])
        for c in range(4):
            channel = bytes(p[c] for p in pixels)
            for i in range(0, width, 128):  # literal runs of up to 128
                chunk = channel[i:i + 128]
                out += bytes([len(chunk)]) + chunk
    return out


def input_seeds(out, folders):
    os.makedirs(out, exist_ok=True)
    written = 0

    def put(name, data):
        nonlocal written
        if len(data) <= SEED_LIMIT:
            with open(os.path.join(out, name), "wb") as f:
                f.write(data)
            written += 1
    for top in folders:
        if not os.path.isdir(top):
            print("fuzz_seeds: %s is absent, skipped" % top)
            continue
        for name in sorted(os.listdir(top)):
            if name.lower().endswith(".exr"):
                with open(os.path.join(top, name), "rb") as f:
                    data = f.read()
                put("sky-" + name, b"\x00" + data)
                put("reference-" + name, b"\x02" + data)
    put("sky-flat.hdr", b"\x01" + hdr_file(16, 8, False))
    put("sky-rle.hdr", b"\x01" + hdr_file(32, 16, True))
    put("writers-small", b"\x03" + bytes([7, 5, 15]) + bytes(range(64)))
    put("writers-nan-inf", b"\x03" + bytes([3, 3, 9]) + b"\x00\x00\xc0\x7f" + b"\x00\x00\x80\x7f" + b"\xff\xff\x7f\x7f")
    print("fuzz_seeds: %d input seeds in %s" % (written, out))


def compressed_seeds(out, folders):
    """Seeds for the compressed target (tests/fuzz/fuzz_compressed_entry.h): every Draco stream and
    every meshopt bufferView of the .glb files under the folders, with the entry's leading bytes."""
    os.makedirs(out, exist_ok=True)
    written = 0
    for top in folders:
        for root, _, files in sorted(os.walk(top)):
            for name in sorted(files):
                if not name.lower().endswith(".glb"):
                    continue
                with open(os.path.join(root, name), "rb") as f:
                    data = f.read()
                json_size = struct.unpack_from("<I", data, 12)[0]
                doc = json.loads(data[20:20 + json_size])
                bin_chunk = data[20 + json_size + 8:]
                views = doc.get("bufferViews", [])
                seeds = []
                for mesh in doc.get("meshes", []):
                    for prim in mesh.get("primitives", []):
                        draco = prim.get("extensions", {}).get("KHR_draco_mesh_compression")
                        if draco:
                            v = views[draco["bufferView"]]
                            start = v.get("byteOffset", 0)
                            seeds.append(b"\x00" + bin_chunk[start:start + v["byteLength"]])
                modes = {"ATTRIBUTES": 0, "TRIANGLES": 1, "INDICES": 2}
                filters = {"NONE": 0, "OCTAHEDRAL": 1, "QUATERNION": 2, "EXPONENTIAL": 3}
                for v in views:
                    m = v.get("extensions", {}).get("EXT_meshopt_compression")
                    if not m or m["count"] > 65535 or m["byteStride"] > 64:
                        continue
                    start = m.get("byteOffset", 0)
                    head = bytes([1, modes[m["mode"]] + 3 * filters[m.get("filter", "NONE")], m["byteStride"] - 1]) + struct.pack("<H", m["count"])
                    seeds.append(head + bin_chunk[start:start + m["byteLength"]])
                for i, seed in enumerate(seeds):
                    with open(os.path.join(out, "%s_%d" % (name, i)), "wb") as f:
                        f.write(seed)
                    written += 1
    print("fuzz_seeds: %d compressed-stream seeds in %s" % (written, out))


def main():
    if len(sys.argv) >= 3 and sys.argv[1] == "--inputs":
        input_seeds(sys.argv[2], sys.argv[3:])
        return
    if len(sys.argv) >= 3 and sys.argv[1] == "--compressed":
        compressed_seeds(sys.argv[2], sys.argv[3:])
        return
    if len(sys.argv) < 3:
        sys.exit("usage: fuzz_seeds.py OUT DIR...")
    out = sys.argv[1]
    os.makedirs(out, exist_ok=True)
    written = skipped = 0
    for top in sys.argv[2:]:
        if not os.path.isdir(top):
            print("fuzz_seeds: %s is absent, skipped" % top)
            continue
        for root, _, files in sorted(os.walk(top)):
            for name in sorted(files):
                path = os.path.join(root, name)
                low = name.lower()
                try:
                    if low.endswith(".gltf"):
                        try:
                            data = embedded_gltf(path)
                        except ValueError:  # not JSON (an invalid-corpus file): the raw bytes are a seed too
                            with open(path, "rb") as f:
                                data = f.read()
                    elif low.endswith(".glb"):
                        with open(path, "rb") as f:
                            data = f.read()
                    else:
                        continue
                except (OSError, RecursionError):
                    skipped += 1
                    continue
                if len(data) > SEED_LIMIT:
                    skipped += 1
                    continue
                seed = os.path.relpath(path, top).replace(os.sep, "_")
                with open(os.path.join(out, os.path.basename(top.rstrip("/")) + "_" + seed), "wb") as f:
                    f.write(data)
                written += 1
    print("fuzz_seeds: %d seeds in %s (%d larger than %d bytes or unreadable, left out)" % (written, out, skipped, SEED_LIMIT))


if __name__ == "__main__":
    main()
