#!/usr/bin/env python3
# furnace_scene.py: writes a white furnace (a closed box whose walls emit LE and reflect diffusely with albedo RHO: radiance LE / (1 - RHO) everywhere) and a constant EXR of that answer.
"""Usage:
    furnace_scene.py OUT.gltf RHO LE       the box [-1,1]^3, faces turned inward, the camera inside
    furnace_scene.py answer RHO LE         prints LE / (1 - RHO)

The reference for pmview's --reference is written with tests/sky_files.py exr (a constant image)."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
import make_scenes as ms  # noqa: E402


def inward_box():
    """make_scenes' box with every face turned toward the inside (winding reversed, normals negated),
    so a one-sided surface emits and reflects into the box whatever the renderer's convention."""
    g = ms.box((-1.0, -1.0, -1.0), (1.0, 1.0, 1.0))
    idx = g["indices"]
    flipped = []
    for t in range(0, len(idx), 3):
        flipped += [idx[t], idx[t + 2], idx[t + 1]]
    return {"positions": g["positions"], "normals": [tuple(-c for c in n) for n in g["normals"]], "indices": flipped}


def furnace(rho, le):
    scene = {"meshes": [ms.mesh("furnace", inward_box(), {"kind": "diffuse", "color": (rho, rho, rho)})],
             "camera": {"eye": (0.0, 0.0, 0.5), "target": (0.3, -0.2, -0.5), "yfov": 1.0, "aspect": 1.0},
             "lights": []}
    doc = ms.to_gltf(scene)
    # a wall that emits and reflects at once: make_scenes' materials are one or the other
    material = doc["materials"][0]
    material["emissiveFactor"] = [1.0, 1.0, 1.0]
    # (beside the specularFactor 0 that keeps the diffuse wall Lambert, as the analytic answer assumes)
    material.setdefault("extensions", {})["KHR_materials_emissive_strength"] = {"emissiveStrength": le}
    used = set(doc.get("extensionsUsed", []))
    used.add("KHR_materials_emissive_strength")
    doc["extensionsUsed"] = sorted(used)
    return doc


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    rho, le = float(sys.argv[2]), float(sys.argv[3])
    if sys.argv[1] == "answer":
        print("%.9g" % (le / (1.0 - rho)))
    else:
        with open(sys.argv[1], "w") as f:
            json.dump(furnace(rho, le), f, separators=(",", ":"))
