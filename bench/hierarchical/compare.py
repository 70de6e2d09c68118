"""Vertex-by-vertex difference between two bakes of the same scene and tessellation (their
_RADIANCE attributes): RMS and largest difference relative to the mean radiance of the lit
(non-emitting) vertices. Usage: compare.py EXACT.glb OTHER.glb"""
import math
import os
import sys
from array import array

sys.path.insert(0, os.path.join(os.path.dirname(__file__), "..", "..", "tests", "blender"))
import glb  # noqa: E402


def radiance(path):
    """_RADIANCE of every primitive that has one (a part of an asset leaves some meshes unbaked)."""
    doc, binary = glb.load(path)
    values = array("f")
    for mesh in doc["meshes"]:
        for prim in mesh["primitives"]:
            if "_RADIANCE" not in prim["attributes"]:
                continue
            acc = doc["accessors"][prim["attributes"]["_RADIANCE"]]
            view = doc["bufferViews"][acc["bufferView"]]
            start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
            values.frombytes(binary[start:start + acc["count"] * 12])
    return values


def main():
    a = radiance(sys.argv[1])
    b = radiance(sys.argv[2])
    assert len(a) == len(b), "different tessellations"
    lum_a = [sum(a[i:i + 3]) / 3 for i in range(0, len(a), 3)]
    lum_b = [sum(b[i:i + 3]) / 3 for i in range(0, len(b), 3)]
    mean = sum(lum_a) / len(lum_a)
    diffs = [abs(x - y) for x, y in zip(lum_a, lum_b)]
    rms = math.sqrt(sum(d * d for d in diffs) / len(diffs))
    if not mean > 0:  # an unlit scene: no mean to relate the differences to
        print(f"vertices {len(lum_a)}  mean {mean:.6g}  rms {rms:.6g}  max {max(diffs):.6g} (absolute: the scene is unlit)")
        return
    print(f"vertices {len(lum_a)}  mean {mean:.6g}  rms {100 * rms / mean:.3f}%  max {100 * max(diffs) / mean:.3f}%")


main()
