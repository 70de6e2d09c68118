#!/usr/bin/python3
"""Write a part of a glTF binary (.glb) asset: the same buffer, nodes and materials, but only the
mesh instances met depth-first through the default scene while the total stays under 1.15 × TARGET
triangles;
the other nodes lose their mesh. Used to measure how the bake scales on the engine's own geometry
at sizes below its full (N = 1) patch count.

Usage: engine_subset.py IN.glb OUT.glb TARGET_TRIANGLES [--tail]
With --tail the instances are taken from the end of that order instead (the 2CylinderEngine's
piston and the bodies around it, another part of the assembly than the head's).
Prints the number of triangle instances kept."""
import json
import struct
import sys


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, _ = struct.unpack_from("<4sII", data, 0)
    assert magic == b"glTF" and version == 2, "not a glTF 2 binary"
    offset, gltf, binary = 12, None, b""
    while offset < len(data):
        length, kind = struct.unpack_from("<I4s", data, offset)
        chunk = data[offset + 8:offset + 8 + length]
        if kind == b"JSON":
            gltf = json.loads(chunk)
        elif kind == b"BIN\0":
            binary = chunk
        offset += 8 + length
    return gltf, binary


def write_glb(path, gltf, binary):
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    body = struct.pack("<I4s", len(text), b"JSON") + text
    if binary:
        body += struct.pack("<I4s", len(binary), b"BIN\0") + binary
    with open(path, "wb") as out:
        out.write(struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


def main():
    if len(sys.argv) not in (4, 5) or sys.argv[4:] not in ([], ["--tail"]):
        sys.exit(__doc__)
    src, dst, target = sys.argv[1], sys.argv[2], int(sys.argv[3])
    tail = sys.argv[4:] == ["--tail"]
    gltf, binary = read_glb(src)
    triangles = []
    for mesh in gltf["meshes"]:
        triangles.append(sum(gltf["accessors"][p["indices"]]["count"] // 3 if "indices" in p
                             else gltf["accessors"][p["attributes"]["POSITION"]]["count"] // 3
                             for p in mesh["primitives"]))
    scene = gltf["scenes"][gltf.get("scene", 0)]
    order = []

    def visit(n):
        order.append(n)
        for c in gltf["nodes"][n].get("children", []):
            visit(c)

    for root in scene["nodes"]:
        visit(root)
    kept = 0
    for n in reversed(order) if tail else order:
        node = gltf["nodes"][n]
        if "mesh" not in node:
            continue
        if kept + triangles[node["mesh"]] <= 1.15 * target:  # skip what would overshoot, take later smaller ones
            kept += triangles[node["mesh"]]
        else:
            del node["mesh"]
    write_glb(dst, gltf, binary)
    print(kept)


if __name__ == "__main__":
    main()
