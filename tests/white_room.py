#!/usr/bin/env python3
# white_room.py: writes a closed room of albedo-1 walls lit by a small ceiling lamp (energy-conserving: Russian roulette never ends a photon path by itself).
"""Usage: python3 tests/white_room.py OUT.gltf [ALBEDO] [dark]

The Cornell box of scenes/make_scenes.py with every wall white at ALBEDO (default 1.0), its
open side closed, and the balls removed; the camera sits inside, near the closed wall. "dark"
removes the lamp too: a closed room with no light inside."""
import json
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "scenes"))
import make_scenes as ms  # noqa: E402


def white_room(albedo, dark=False):
    scene = ms.cornell_box(segments=8)
    white = {"kind": "diffuse", "color": (albedo, albedo, albedo)}
    dropped = ("mirror_ball", "glass_ball") + (("lamp",) if dark else ())
    meshes = [m for m in scene["meshes"] if m["name"] not in dropped]
    for m in meshes:
        if m["material"]["kind"] == "diffuse":
            m["material"] = white
    meshes.append(ms.mesh("front", ms.quad([(1, 0, 1), (-1, 0, 1), (-1, 2, 1), (1, 2, 1)], (0, 0, -1)), white))
    scene["meshes"] = meshes
    scene["camera"] = {"eye": (0.0, 1.0, 0.95), "target": (0.0, 1.0, 0.0), "yfov": 1.2, "aspect": 1.0}
    return scene


if __name__ == "__main__":
    albedo = float(sys.argv[2]) if len(sys.argv) > 2 else 1.0
    with open(sys.argv[1], "w") as f:
        json.dump(ms.to_gltf(white_room(albedo, len(sys.argv) > 3 and sys.argv[3] == "dark")), f, separators=(",", ":"))
