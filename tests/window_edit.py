#!/usr/bin/env python3
# window_edit.py: rewrites a glTF scene as an editor would, for tests/test_window_reload.sh: a material's base colour and the camera node's position changed.
"""Usage: window_edit.py IN.gltf OUT.gltf [--colour MATERIAL R G B] [--camera-shift DX DY DZ] [--broken]

--colour sets material MATERIAL's baseColorFactor; --camera-shift moves every camera node;
--broken writes the first half of the JSON text only (a save cut short)."""
import argparse
import json

ap = argparse.ArgumentParser()
ap.add_argument("src")
ap.add_argument("out")
ap.add_argument("--colour", nargs=4)
ap.add_argument("--camera-shift", nargs=3, type=float)
ap.add_argument("--broken", action="store_true")
o = ap.parse_args()
doc = json.load(open(o.src))
if o.colour:
    m = doc["materials"][int(o.colour[0])]
    m.setdefault("pbrMetallicRoughness", {})["baseColorFactor"] = [float(x) for x in o.colour[1:]] + [1.0]
if o.camera_shift:
    for node in doc["nodes"]:
        if "camera" in node:
            t = node.get("translation", [0.0, 0.0, 0.0])
            node["translation"] = [t[k] + o.camera_shift[k] for k in range(3)]
text = json.dumps(doc)
if o.broken:
    text = text[:len(text) // 2]
with open(o.out, "w") as f:
    f.write(text)
