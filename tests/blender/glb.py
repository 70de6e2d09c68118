"""Reads what the Blender-made tests check in a .glb: the JSON document, the binary chunk and the
_RADIANCE values (VEC3 float) of every primitive, in order."""
import json
import struct
from array import array


def load(path):
    data = open(path, "rb").read()
    n = struct.unpack_from("<I", data, 12)[0]
    return json.loads(data[20:20 + n]), data[20 + n + 8:]


def radiance(doc, binary):
    values = array("f")
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            acc = doc["accessors"][prim["attributes"]["_RADIANCE"]]
            view = doc["bufferViews"][acc["bufferView"]]
            start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
            values.frombytes(binary[start:start + acc["count"] * 12])
    return values
