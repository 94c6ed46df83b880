#!/usr/bin/env python3
# big_scene.py: writes a large test scene (.glb): a bumpy height field of about N million triangles under a sun, for the bench's load, BVH and window figures.
"""Usage: python3 bench/big_scene.py OUT.glb MILLIONS [--smooth]

A square height field of k x k quads (2 k^2 triangles, k chosen so that 2 k^2 is about MILLIONS
x 10^6), its height a sum of sines so that the sun casts shadows and the BVH has depth to sort,
one diffuse grey material, a directional light (KHR_lights_punctual) and no camera: pmview frames
it. Without --smooth the file has no NORMAL, so each triangle is shaded flat and gets vertices of
its own (3 per triangle); --smooth writes the field's normals, so neighbours share vertices (about
one per two triangles), as exported meshes do. The file is written by numpy in a few seconds; it is generated at bench time, never committed."""
import json
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tools"))
import glb  # noqa: E402


def height_field(k):
    """Positions (float32, (k+1)^2 x 3) and triangle indices (uint32, 2 k^2 x 3) of a field on [-1,1]^2."""
    t = np.linspace(-1.0, 1.0, k + 1, dtype=np.float32)
    x, z = np.meshgrid(t, t, indexing="xy")
    y = 0.06 * np.sin(9.0 * x) * np.cos(7.0 * z) + 0.03 * np.sin(31.0 * x + 23.0 * z) + 0.012 * np.sin(97.0 * z - 61.0 * x)
    positions = np.stack([x, y.astype(np.float32), z], axis=-1).reshape(-1, 3).astype(np.float32)
    row = np.arange(k, dtype=np.uint32)
    i = (row[None, :] + (k + 1) * row[:, None]).reshape(-1)  # each quad's corner at (x, z)
    a, b, c, d = i, i + 1, i + (k + 1), i + (k + 2)
    # counter-clockwise seen from +y, so the front face looks up at the sun
    tri = np.empty((k * k, 2, 3), dtype=np.uint32)
    tri[:, 0] = np.stack([a, c, b], axis=-1)
    tri[:, 1] = np.stack([b, c, d], axis=-1)
    return positions, tri.reshape(-1, 3)


def height_field_normals(positions):
    """Unit normals (float32) of the field at the given positions: (-dy/dx, 1, -dy/dz), normalised."""
    x, z = positions[:, 0].astype(np.float64), positions[:, 2].astype(np.float64)
    dx = 0.54 * np.cos(9.0 * x) * np.cos(7.0 * z) + 0.93 * np.cos(31.0 * x + 23.0 * z) - 0.732 * np.cos(97.0 * z - 61.0 * x)
    dz = -0.42 * np.sin(9.0 * x) * np.sin(7.0 * z) + 0.69 * np.cos(31.0 * x + 23.0 * z) + 1.164 * np.cos(97.0 * z - 61.0 * x)
    n = np.stack([-dx, np.ones_like(dx), -dz], axis=-1)
    return (n / np.linalg.norm(n, axis=1, keepdims=True)).astype(np.float32)


def write_glb(path, positions, indices, normals=None):
    pos_bytes = positions.tobytes() + (normals.tobytes() if normals is not None else b"")
    idx_bytes = indices.tobytes()
    lo, hi = positions.min(axis=0), positions.max(axis=0)
    gltf = {
        "asset": {"version": "2.0", "generator": "pmview bench/big_scene.py"},
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "directional", "color": [1.0, 0.95, 0.85], "intensity": 3.0}]}},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0},
            # the sun's -z axis pointed down and across the bumps: long shadows
            {"rotation": [-0.3535534, 0.3535534, 0.1464466, 0.8535534], "extensions": {"KHR_lights_punctual": {"light": 0}}},
        ],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.7, 0.7, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1, "material": 0}]}],
        "buffers": [{"byteLength": len(pos_bytes) + len(idx_bytes)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": len(pos_bytes), "target": 34962},
            {"buffer": 0, "byteOffset": len(pos_bytes), "byteLength": len(idx_bytes), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(positions), "type": "VEC3",
             "min": [float(v) for v in lo], "max": [float(v) for v in hi]},
            {"bufferView": 1, "componentType": 5125, "count": indices.size, "type": "SCALAR"},
        ],
    }
    if normals is not None:
        gltf["meshes"][0]["primitives"][0]["attributes"]["NORMAL"] = 2
        gltf["accessors"].append({"bufferView": 0, "byteOffset": positions.nbytes, "componentType": 5126,
                                  "count": len(normals), "type": "VEC3"})
    glb.write_glb(path, json.dumps(gltf, separators=(",", ":")).encode(), pos_bytes + idx_bytes)


if __name__ == "__main__":
    if len(sys.argv) not in (3, 4) or (len(sys.argv) == 4 and sys.argv[3] != "--smooth"):
        sys.exit(__doc__)
    k = max(1, int(round(math.sqrt(float(sys.argv[2]) * 1e6 / 2.0))))
    positions, indices = height_field(k)
    write_glb(sys.argv[1], positions, indices, height_field_normals(positions) if len(sys.argv) == 4 else None)
    print(f"big_scene: {sys.argv[1]}: {len(indices)} triangles")
