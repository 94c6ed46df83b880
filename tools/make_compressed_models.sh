#!/bin/sh
# make_compressed_models.sh: writes tests/models/duck/: the Duck sample model as a plain GLB, as its Draco-compressed GLB and as a meshopt-compressed GLB made by gltfpack.
#
#   sh tools/make_compressed_models.sh [DUCK_FOLDER]   (default /work/shared/real-models/Duck; needs gltfpack and python3)
#
# The plain and Draco files are the sample's own .gltf files packed into GLB unchanged (buffers and
# images concatenated into the BIN chunk, in order); the meshopt one is gltfpack -cc's output from
# the plain .gltf (quantized, KHR_mesh_quantization, EXT_meshopt_compression).
set -e
duck=${1:-/work/shared/real-models/Duck}
out=tests/models/duck
mkdir -p $out
cp "$duck/LICENSE.md" $out/LICENSE.md
pack() {
    python3 - "$1" "$2" <<'PY'
import json, os, struct, sys
src, dst = sys.argv[1], sys.argv[2]
folder = os.path.dirname(src)
doc = json.load(open(src))
blob = b""
def append(data):
    global blob
    offset = len(blob)
    blob += data + b"\0" * (-len(data) % 4)
    return offset
offsets = [append(open(os.path.join(folder, b["uri"]), "rb").read()) for b in doc["buffers"]]
for view in doc.get("bufferViews", []):
    view["byteOffset"] = view.get("byteOffset", 0) + offsets[view["buffer"]]
    view["buffer"] = 0
for image in doc.get("images", []):
    data = open(os.path.join(folder, image.pop("uri")), "rb").read()
    doc["bufferViews"].append({"buffer": 0, "byteOffset": append(data), "byteLength": len(data)})
    image["bufferView"] = len(doc["bufferViews"]) - 1
    image["mimeType"] = "image/png"
doc["buffers"] = [{"byteLength": len(blob)}]
text = json.dumps(doc, separators=(",", ":")).encode()
text += b" " * (-len(text) % 4)
chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob), 0x004E4942) + blob
open(dst, "wb").write(struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks)
PY
}
pack "$duck/glTF/Duck.gltf" $out/duck.glb
pack "$duck/glTF-Draco/Duck.gltf" $out/duck-draco.glb
gltfpack -i "$duck/glTF/Duck.gltf" -o $out/duck-meshopt.glb -cc
ls -l $out
