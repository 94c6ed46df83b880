#!/usr/bin/env python3
# gpu_instancing_scene.py: writes a .glb placing one small box N times, by EXT_mesh_gpu_instancing or by as many nodes with the same transforms, and broken variants of the extension.
"""Usage: python3 tests/gpu_instancing_scene.py OUT.glb [--instances N] [--form gpu|nodes] [--bad KIND]

A box of 12 triangles placed N times on a square grid, each turned about its own axis and scaled
between 0.5 and 1.1, under a parent node that moves and turns them all (so the instance transforms
compose with the node's); a floor and a directional sun light them, a camera looks down at the grid.
--form gpu: one node with the mesh and EXT_mesh_gpu_instancing (TRANSLATION, ROTATION, SCALE);
--form nodes: one child node per instance with the same translation, rotation and scale, in the
same order. --bad: type (TRANSLATION as VEC2), count (SCALE one short), nan (a TRANSLATION
component), rotation (a zero quaternion), zero-scale (instance 1 scaled to 0 in y), missing (no
attributes). Python standard library only."""
import argparse
import array
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from glb import pack_blobs, quaternion, write_glb  # noqa: E402


def box():
    pos, nrm, idx = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u, v = [(axis + 1) % 3, (axis + 2) % 3]
            base = len(pos) // 3
            for a, b in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                p = [0.0, 0.0, 0.0]
                p[axis], p[u], p[v] = 0.5 * sign, 0.5 * a, 0.5 * b
                pos += p
                nrm += n
            quad = [base, base + 1, base + 2, base, base + 2, base + 3]
            if sign < 0:
                quad = [base, base + 2, base + 1, base, base + 3, base + 2]
            idx += quad
    return pos, nrm, idx


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--instances", type=int, default=64)
    ap.add_argument("--form", choices=["gpu", "nodes"], default="gpu")
    ap.add_argument("--bad", choices=["type", "count", "nan", "rotation", "zero-scale", "missing"])
    o = ap.parse_args()
    n = o.instances
    k = max(1, int(math.ceil(math.sqrt(n))))
    t, r, s = array.array("f"), array.array("f"), array.array("f")
    for i in range(n):
        row, col = divmod(i, k)
        t.extend([1.5 * col - 0.75 * k, 0.0, 1.5 * row - 0.75 * k])
        r.extend(quaternion([math.sin(i * 1.7), 1.0, math.cos(i * 2.3)], 0.7 * i))
        sc = 0.5 + 0.6 * ((i * 37) % 11) / 10.0
        s.extend([sc, sc, sc])
    if o.bad == "nan":
        t[3 * (n // 2) + 1] = float("nan")
    if o.bad == "rotation":
        r[4:8] = array.array("f", [0.0, 0.0, 0.0, 0.0])
    if o.bad == "zero-scale":
        s[3 * 1 + 1] = 0.0
    pos, nrm, idx = box()
    half = 0.75 * k + 2
    floor = [-half, -0.6, -half, half, -0.6, -half, half, -0.6, half, -half, -0.6, half]
    blobs = [struct.pack("<%df" % len(pos), *pos), struct.pack("<%df" % len(nrm), *nrm), struct.pack("<%dH" % len(idx), *idx),
             struct.pack("<12f", *floor), struct.pack("<6H", 0, 3, 2, 0, 2, 1)]
    if o.form == "gpu":
        blobs += [t.tobytes(), r.tobytes(), s.tobytes() if o.bad != "count" else s[:-3].tobytes()]
    views, binary = pack_blobs(blobs)
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(pos) // 3, "type": "VEC3", "min": [-0.5] * 3, "max": [0.5] * 3},
        {"bufferView": 1, "componentType": 5126, "count": len(nrm) // 3, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": len(idx), "type": "SCALAR"},
        {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC3", "min": [-half, -0.6, -half], "max": [half, -0.6, half]},
        {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"},
    ]
    meshes = [{"primitives": [{"attributes": {"POSITION": 3}, "indices": 4, "material": 1}]},
              {"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}]}]
    eye = [0.0, 0.9 * k + 3, 1.2 * k + 3]
    pitch = math.atan2(eye[1], eye[2])
    nodes = [{"mesh": 0},
             {"rotation": [-0.3535534, 0.3535534, 0.1464466, 0.8535534], "extensions": {"KHR_lights_punctual": {"light": 0}}},
             {"camera": 0, "translation": eye, "rotation": quaternion([1, 0, 0], -pitch)},
             {"translation": [0.3, 0.0, -0.2], "rotation": quaternion([0, 1, 0], 0.15), "children": []}]
    parent = nodes[3]
    used = ["KHR_lights_punctual"]
    if o.form == "gpu":
        accessors += [{"bufferView": 5, "componentType": 5126, "count": n, "type": "VEC2" if o.bad == "type" else "VEC3"},
                      {"bufferView": 6, "componentType": 5126, "count": n, "type": "VEC4"},
                      {"bufferView": 7, "componentType": 5126, "count": n - 1 if o.bad == "count" else n, "type": "VEC3"}]
        attributes = {} if o.bad == "missing" else {"TRANSLATION": 5, "ROTATION": 6, "SCALE": 7}
        parent["children"].append(len(nodes))
        nodes.append({"mesh": 1, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}})
        used.append("EXT_mesh_gpu_instancing")
    else:
        for i in range(n):
            parent["children"].append(len(nodes))
            nodes.append({"mesh": 1, "translation": list(t[3 * i:3 * i + 3]), "rotation": list(r[4 * i:4 * i + 4]),
                          "scale": list(s[3 * i:3 * i + 3])})
    gltf = {
        "asset": {"version": "2.0", "generator": "pmview tests/gpu_instancing_scene.py"},
        "extensionsUsed": used,
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": nodes,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "aspectRatio": 1.0, "znear": 0.01}}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0], "metallicFactor": 0.0}},
                      {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0}}],
        "meshes": meshes,
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    write_glb(o.out, json.dumps(gltf, separators=(",", ":")).encode(), binary)


if __name__ == "__main__":
    main()
