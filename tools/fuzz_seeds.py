#!/usr/bin/env python3
"""fuzz_seeds.py: turns the glTF files under the given folders into self-contained fuzz seeds (one file each) in OUT.

The fuzz target loads from memory, so a .gltf's external buffers and images are embedded as
data: URIs; an image file above IMAGE_LIMIT bytes is replaced by a 2x2 PNG (the mutator gains
nothing from megabytes of pixels, and every execution would decode them). A .glb is copied as
it is. Seeds above SEED_LIMIT are left out: each execution of one costs seconds under
ASan (run-fuzz.sh gives libFuzzer the same -max_len). Missing folders are skipped. Standard library only.

    python3 tools/fuzz_seeds.py OUT DIR...
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


def main():
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
