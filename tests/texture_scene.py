#!/usr/bin/env python3
# texture_scene.py: writes a glTF of textured quads, each with a PNG of a given size (or one whose header only claims it), for the memory-limit tests.
"""Usage: python3 tests/texture_scene.py OUT.gltf SIZE [SIZE ...]

One quad per SIZE, side by side, each with its own baseColor texture: a SIZE x SIZE RGBA PNG
written beside OUT.gltf. A SIZE written "claim:N" gives a PNG whose header says N x N but whose
pixel data is a single short row: refusing it from the header costs nothing, decoding it would
be needed to find that out. A SIZE written "deep:N" gives an N x N PNG of 16-bit channels, which
is decoded (8 bytes a pixel, 16 while stb's copy is made) and then ignored (pmview reads 8-bit
textures). The scene has no light (pmview gives it the default sky)."""
import json
import os
import struct
import sys
import zlib


def chunk(kind, data):
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)


def png(side, claimed_only, deep=False):
    header = struct.pack(">IIBBBBB", side, side, 16 if deep else 8, 6, 0, 0, 0)  # RGBA
    if claimed_only:
        pixels = zlib.compress(b"\0" + b"\x80" * 16)
    else:
        texel = bytes((200, 0, 120, 0, 40, 0, 255, 255)) if deep else bytes((200, 120, 40, 255))
        row = b"\0" + texel * side  # filter 0, one colour: compresses to little
        pixels = zlib.compress(row * side, 9)
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", pixels) + chunk(b"IEND", b"")


def write(path, sizes):
    folder, stem = os.path.dirname(os.path.abspath(path)), os.path.splitext(os.path.basename(path))[0]
    positions, normals, uvs, indices = [], [], [], []
    for q in range(len(sizes)):
        x = 1.1 * q
        positions += [x, 0, 0, x + 1, 0, 0, x + 1, 1, 0, x, 1, 0]
        normals += [0, 0, 1] * 4
        uvs += [0, 1, 1, 1, 1, 0, 0, 0]
    for q in range(len(sizes)):
        indices += [4 * q, 4 * q + 1, 4 * q + 2, 4 * q, 4 * q + 2, 4 * q + 3]
    blobs = [struct.pack("<%df" % len(positions), *positions), struct.pack("<%df" % len(normals), *normals),
             struct.pack("<%df" % len(uvs), *uvs), struct.pack("<%dI" % len(indices), *indices)]
    data, views, offset = b"", [], 0
    for b in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b)})
        data += b
        offset += len(b)
    n = 4 * len(sizes)
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": n, "type": "VEC3",
         "min": [0, 0, 0], "max": [1.1 * (len(sizes) - 1) + 1, 1, 0]},
        {"bufferView": 1, "componentType": 5126, "count": n, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": n, "type": "VEC2"},
    ]
    meshes, materials, textures, images = [], [], [], []
    for q, size in enumerate(sizes):
        claimed, deep = str(size).startswith("claim:"), str(size).startswith("deep:")
        side = int(str(size).split(":")[-1])
        name = "%s-%d.png" % (stem, q)
        with open(os.path.join(folder, name), "wb") as f:
            f.write(png(side, claimed, deep))
        images.append({"uri": name})
        textures.append({"source": q})
        materials.append({"pbrMetallicRoughness": {"baseColorTexture": {"index": q}, "metallicFactor": 0}})
        accessors.append({"bufferView": 3, "byteOffset": 24 * q, "componentType": 5125, "count": 6, "type": "SCALAR"})
        meshes.append({"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
                                       "indices": 3 + q, "material": q}]})
    gltf = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": list(range(len(sizes)))}],
        "nodes": [{"mesh": q} for q in range(len(sizes))],
        "meshes": meshes, "materials": materials, "textures": textures, "images": images,
        "accessors": accessors, "bufferViews": views,
        "buffers": [{"byteLength": len(data), "uri": stem + ".bin"}],
    }
    with open(os.path.join(folder, stem + ".bin"), "wb") as f:
        f.write(data)
    with open(path, "w") as f:
        json.dump(gltf, f)


if __name__ == "__main__":
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    write(sys.argv[1], sys.argv[2:])
