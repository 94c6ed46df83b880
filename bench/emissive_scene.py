#!/usr/bin/env python3
# emissive_scene.py: writes a room lit by one finely tessellated emissive sphere (.glb), for the bench's photon-tracing figure where the emitters outgrow the caches.
"""Usage: python3 bench/emissive_scene.py OUT.glb TRIANGLES

A closed room 4 x 3 x 4 (six inward-facing quads, grey, metallic 0), a sphere of radius 0.3 near
the ceiling tessellated into about TRIANGLES triangles (latitude-longitude), emissive (factor 1,
KHR_materials_emissive_strength 10) over a black base, and a camera inside. Every photon starts on
one of the sphere's triangles, picked by power: with 200,000 of them the emitter tables are
megabytes, so a photon's start reads memory no cache holds. Generated at bench time, never committed."""
import json
import math
import os
import struct
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import glb  # noqa: E402


def room():
    """Positions and triangles of the room's six quads, front faces inward."""
    L, H = 2.0, 3.0
    quads = [
        [(-L, 0, L), (L, 0, L), (L, 0, -L), (-L, 0, -L)],  # floor, up
        [(-L, H, -L), (L, H, -L), (L, H, L), (-L, H, L)],  # ceiling, down
        [(-L, 0, -L), (L, 0, -L), (L, H, -L), (-L, H, -L)],  # back, toward +z
        [(L, 0, L), (-L, 0, L), (-L, H, L), (L, H, L)],  # front, toward -z
        [(L, 0, -L), (L, 0, L), (L, H, L), (L, H, -L)],  # right, toward -x
        [(-L, 0, L), (-L, 0, -L), (-L, H, -L), (-L, H, L)],  # left, toward +x
    ]
    positions, triangles = [], []
    for q in quads:
        base = len(positions)
        positions += q
        triangles += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
    return positions, triangles


def sphere(triangles, centre=(0.0, 2.2, 0.0), radius=0.3):
    """A latitude-longitude sphere of about `triangles` triangles, front faces outward."""
    rings = max(2, int(round(math.sqrt(triangles / 4.0))))
    segments = max(3, int(round(triangles / (2.0 * rings))))
    positions, faces = [], []
    for i in range(rings + 1):
        theta = math.pi * i / rings
        for j in range(segments):
            phi = 2.0 * math.pi * j / segments
            positions.append((centre[0] + radius * math.sin(theta) * math.cos(phi), centre[1] + radius * math.cos(theta),
                              centre[2] + radius * math.sin(theta) * math.sin(phi)))
    for i in range(rings):
        for j in range(segments):
            a, b = i * segments + j, i * segments + (j + 1) % segments
            c, d = a + segments, b + segments
            if i > 0:
                faces.append((a, b, d))
            if i < rings - 1:
                faces.append((a, d, c))
    return positions, faces


def pack(positions, triangles):
    return b"".join(struct.pack("<3f", *p) for p in positions), b"".join(struct.pack("<3I", *t) for t in triangles)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    meshes = [room(), sphere(int(sys.argv[2]))]
    blobs, accessors = [], []
    for positions, triangles in meshes:
        pos, idx = pack(positions, triangles)
        blobs += [pos, idx]
        lo = [min(p[k] for p in positions) for k in range(3)]
        hi = [max(p[k] for p in positions) for k in range(3)]
        accessors.append({"bufferView": len(blobs) - 2, "componentType": 5126, "count": len(positions), "type": "VEC3",
                          "min": lo, "max": hi})
        accessors.append({"bufferView": len(blobs) - 1, "componentType": 5125, "count": 3 * len(triangles), "type": "SCALAR"})
    views, binary = glb.pack_blobs(blobs)
    gltf = {
        "asset": {"version": "2.0", "generator": "pmview bench/emissive_scene.py"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [{"mesh": 0}, {"mesh": 1}, {"camera": 0, "translation": [0.0, 1.5, 1.9]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.01}}],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0}},
            {"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
             "emissiveFactor": [1.0, 1.0, 1.0], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 10.0}}},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 2 * k}, "indices": 2 * k + 1, "material": k}]} for k in range(2)],
        "buffers": [{"byteLength": len(binary)}],
        "bufferViews": views,
        "accessors": accessors,
    }
    glb.write_glb(sys.argv[1], json.dumps(gltf, separators=(",", ":")).encode(), binary)
    print(f"emissive_scene: {sys.argv[1]}: {len(meshes[1][1])} emissive triangles")
