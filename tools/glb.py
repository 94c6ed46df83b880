# glb.py: what the scripts that write .glb files share: packing binary blobs into one buffer, the GLB container, a rotation quaternion.
import math
import struct


def pack_blobs(blobs):
    """One buffer from `blobs` (bytes), each 4-byte aligned: (bufferViews, the buffer's bytes)."""
    views, offset = [], 0
    for blob in blobs:
        views.append({"buffer": 0, "byteOffset": offset, "byteLength": len(blob)})
        offset += (len(blob) + 3) // 4 * 4
    return views, b"".join(blob + b"\0" * (-len(blob) % 4) for blob in blobs)


def write_glb(path, text, binary):
    """A GLB of the JSON `text` (bytes) and the buffer `binary`, both padded to 4 bytes as the container requires."""
    text = text + b" " * (-len(text) % 4)
    binary = binary + b"\0" * (-len(binary) % 4)
    with open(path, "wb") as f:
        f.write(struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(binary)))
        f.write(struct.pack("<II", len(text), 0x4E4F534A) + text)
        f.write(struct.pack("<II", len(binary), 0x004E4942))
        f.write(binary)


def quaternion(axis, angle):
    """glTF's rotation [x, y, z, w] turning by `angle` radians about `axis` (any length)."""
    n = math.sqrt(sum(x * x for x in axis))
    s = math.sin(angle / 2) / n
    return [axis[0] * s, axis[1] * s, axis[2] * s, math.cos(angle / 2)]
