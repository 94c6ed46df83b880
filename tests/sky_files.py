#!/usr/bin/env python3
# sky_files.py: writes the small (and the hostile) environment maps, references and the plane scene that tests/test_hostile_sky.sh feeds pmview.
"""Usage:
    sky_files.py exr OUT.exr W H VALUE [X Y HOT]     FLOAT R,G,B of VALUE, texel (X, Y) at HOT (row 0 = the zenith)
    sky_files.py exr-header OUT.exr W H              the header alone, claiming W x H texels (no pixels)
    sky_files.py hdr OUT.hdr W H VALUE [X Y HOT]     Radiance RGBE, run-length encoded rows (flat when W < 8)
    sky_files.py hdr-header OUT.hdr W H              the header and resolution line alone
    sky_files.py plane OUT.gltf ALBEDO               a 2 km square of grey ground, the camera 1 m above it looking down at 45 degrees
    sky_files.py horizon OUT.gltf ALBEDO             the same ground, the camera 1 m above it looking level along -Z (yfov 1, aspect 2)

EXR is written by hand (no compression, one line a chunk), so the tests need no Python package."""
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
import make_scenes as ms  # noqa: E402


def texels(w, h, value, hot):
    img = [[value] * w for _ in range(h)]
    if hot:
        x, y, v = hot
        img[y][x] = v
    return img


def attr(name, kind, data):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(data)) + data


def exr_header(w, h):
    channels = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    return (b"\x76\x2f\x31\x01" + struct.pack("<i", 2) + attr("channels", "chlist", channels) +
            attr("compression", "compression", b"\0") + attr("dataWindow", "box2i", box) +
            attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0") +
            attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
            attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)) +
            attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")


def write_exr(path, img):
    h, w = len(img), len(img[0])
    head = exr_header(w, h)
    # each chunk: y, byte count, then the line of each channel in the header's (alphabetical) order
    chunks = [struct.pack("<ii", y, 12 * w) + struct.pack("<%df" % w, *row) * 3 for y, row in enumerate(img)]
    offset = len(head) + 8 * h
    table = b""
    for c in chunks:
        table += struct.pack("<Q", offset)
        offset += len(c)
    with open(path, "wb") as f:
        f.write(head + table + b"".join(chunks))


def rgbe(v):
    if not v > 0:
        return (0, 0, 0, 0)
    m, e = math.frexp(v)
    return (int(m * 256),) * 3 + (e + 128,)


def rle(values):
    """One component of a row: runs of 3 or more as (128 + n, byte), the rest as literal dumps."""
    out, i, n = bytearray(), 0, len(values)
    while i < n:
        run = 1
        while i + run < n and run < 127 and values[i + run] == values[i]:
            run += 1
        if run >= 3:
            out += bytes((128 + run, values[i]))
            i += run
            continue
        j = i
        while j < n and j - i < 128 and not (j + 2 < n and values[j] == values[j + 1] == values[j + 2]):
            j += 1
        out += bytes((j - i,)) + bytes(values[i:j])
        i = j
    return bytes(out)


def hdr_header(w, h):
    return b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w)


def write_hdr(path, img):
    h, w = len(img), len(img[0])
    body = bytearray()
    for row in img:
        pixels = [rgbe(v) for v in row]
        if w < 8:
            body += b"".join(bytes(p) for p in pixels)
            continue
        body += bytes((2, 2, w >> 8, w & 255))
        for c in range(4):
            body += rle([p[c] for p in pixels])
    with open(path, "wb") as f:
        f.write(hdr_header(w, h) + body)


def plane(albedo, level=False):
    grey = {"kind": "diffuse", "color": (albedo, albedo, albedo)}
    ground = ms.quad([(-1000, 0, 1000), (1000, 0, 1000), (1000, 0, -1000), (-1000, 0, -1000)], (0, 1, 0))
    camera = {"eye": (0.0, 1.0, 0.0), "target": (0.0, 0.0, -1.0), "yfov": 0.5, "aspect": 1.0}
    if level:
        camera = {"eye": (0.0, 1.0, 0.0), "target": (0.0, 1.0, -1.0), "yfov": 1.0, "aspect": 2.0}
    return {"meshes": [ms.mesh("ground", ground, grey)], "lights": [], "camera": camera}


def main(argv):
    kind, out = argv[1], argv[2]
    if kind in ("plane", "horizon"):
        with open(out, "w") as f:
            json.dump(ms.to_gltf(plane(float(argv[3]), kind == "horizon")), f, separators=(",", ":"))
        return
    w, h = int(argv[3]), int(argv[4])
    if kind.endswith("-header"):
        with open(out, "wb") as f:
            f.write(exr_header(w, h) if kind == "exr-header" else hdr_header(w, h))
        return
    hot = (int(argv[6]), int(argv[7]), float(argv[8])) if len(argv) > 8 else None
    img = texels(w, h, float(argv[5]), hot)
    (write_exr if kind == "exr" else write_hdr)(out, img)


if __name__ == "__main__":
    main(sys.argv)
