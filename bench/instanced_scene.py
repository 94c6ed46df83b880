#!/usr/bin/env python3
# instanced_scene.py: writes a .glb that places one torus mesh of about N triangles P times (instancing figures, issue 30).
"""Usage: python3 bench/instanced_scene.py OUT.glb [--placements P] [--triangles N] [--flat] [--emissive]

One torus (positions, normals, TEXCOORD_0; about N triangles) placed by P nodes on a square grid,
each rotated about its own axis and scaled between 0.6 and 1.2. Rows of the grid are parent nodes
with their own translation and a turn growing by 0.02 rad a row, so every placement is a placement of a placement
(transforms compose). A floor quad under the grid and a directional sun (KHR_lights_punctual)
light it. --flat: every node gets a mesh of its own (the same accessors), so pmview flattens
them: the same geometry as the instanced file, for image comparisons. --emissive: the torus
glows (emissiveFactor) and the sun is dimmed. Python standard library only."""
import argparse
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
from glb import pack_blobs, quaternion, write_glb  # noqa: E402


def torus(triangles):
    """Positions, normals, uvs (flat lists) and indices of a torus (radii 1 and 0.35) of about `triangles` triangles."""
    a = max(3, int(math.ceil(math.sqrt(triangles / 2.0))))
    b = max(3, int(math.ceil(triangles / (2.0 * a))))
    pos, nrm, uv, idx = [], [], [], []
    for i in range(a + 1):
        u = 2 * math.pi * i / a
        for j in range(b + 1):
            v = 2 * math.pi * j / b
            n = (math.cos(u) * math.cos(v), math.sin(v), math.sin(u) * math.cos(v))
            c = (math.cos(u), 0.0, math.sin(u))
            pos += [c[k] + 0.35 * n[k] for k in range(3)]
            nrm += list(n)
            uv += [i / a, j / b]
    for i in range(a):
        for j in range(b):
            p, q, r, s = i * (b + 1) + j, (i + 1) * (b + 1) + j, (i + 1) * (b + 1) + j + 1, i * (b + 1) + j + 1
            # counter-clockwise seen from outside: the normal above points out
            idx += [p, s, q, q, s, r]
    return pos, nrm, uv, idx


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--placements", type=int, default=100)
    ap.add_argument("--triangles", type=int, default=2000)
    ap.add_argument("--flat", action="store_true")
    ap.add_argument("--emissive", action="store_true")
    o = ap.parse_args()
    pos, nrm, uv, idx = torus(o.triangles)
    blobs = [struct.pack("<%df" % len(pos), *pos), struct.pack("<%df" % len(nrm), *nrm),
             struct.pack("<%df" % len(uv), *uv), struct.pack("<%dI" % len(idx), *idx)]
    k = max(1, int(math.ceil(math.sqrt(o.placements))))
    half = 1.5 * k
    floor = [-half - 2, -0.6, -half - 2, half + 2, -0.6, -half - 2, half + 2, -0.6, half + 2, -half - 2, -0.6, half + 2]
    blobs += [struct.pack("<12f", *floor), struct.pack("<6I", 0, 3, 2, 0, 2, 1)]
    views, binary = pack_blobs(blobs)
    lo = [min(pos[c::3]) for c in range(3)]
    hi = [max(pos[c::3]) for c in range(3)]
    accessors = [
        {"bufferView": 0, "componentType": 5126, "count": len(pos) // 3, "type": "VEC3", "min": lo, "max": hi},
        {"bufferView": 1, "componentType": 5126, "count": len(nrm) // 3, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5126, "count": len(uv) // 2, "type": "VEC2"},
        {"bufferView": 3, "componentType": 5125, "count": len(idx), "type": "SCALAR"},
        {"bufferView": 4, "componentType": 5126, "count": 4, "type": "VEC3",
         "min": [-half - 2, -0.6, -half - 2], "max": [half + 2, -0.6, half + 2]},
        {"bufferView": 5, "componentType": 5125, "count": 6, "type": "SCALAR"},
    ]
    torus_primitive = {"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}
    meshes = [{"primitives": [{"attributes": {"POSITION": 4}, "indices": 5, "material": 1}]}, {"primitives": [torus_primitive]}]
    nodes = [{"mesh": 0}, {"rotation": [-0.3535534, 0.3535534, 0.1464466, 0.8535534],
                           "extensions": {"KHR_lights_punctual": {"light": 0}}}]
    roots = [0, 1]
    placed = 0
    for row in range(k):
        if placed >= o.placements:
            break
        parent = {"translation": [0.0, 0.0, 3.0 * row - half + 1.5], "rotation": quaternion([0, 1, 0], 0.02 * row), "children": []}
        roots.append(len(nodes))
        nodes.append(parent)
        for col in range(k):
            if placed >= o.placements:
                break
            mesh = 1
            if o.flat:
                mesh = len(meshes)
                meshes.append({"primitives": [torus_primitive]})
            axis = [math.sin(placed * 1.7), 1.0, math.cos(placed * 2.3)]
            parent["children"].append(len(nodes))
            nodes.append({"mesh": mesh, "translation": [3.0 * col - half + 1.5, 0.0, 0.0],
                          "rotation": quaternion(axis, 0.7 * placed), "scale": [0.6 + 0.6 * ((placed * 37) % 11) / 10.0] * 3})
            placed += 1
    material = {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.5, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}
    if o.emissive:
        material["emissiveFactor"] = [1.0, 0.9, 0.7]
    gltf = {
        "asset": {"version": "2.0", "generator": "pmview bench/instanced_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 0.3 if o.emissive else 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": roots}],
        "nodes": nodes,
        "materials": [material, {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0}}],
        "meshes": meshes,
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    write_glb(o.out, json.dumps(gltf, separators=(",", ":")).encode(), binary)


if __name__ == "__main__":
    main()
