"""Probe points on what a viewer sees of issue 16's room (bench/room/make_room.py at its sizes): the
floor, the four walls and the ceiling on a 10-cm grid (the ceiling without the lamp's footprint and a
5-cm rim: the bright ceiling above the lamp is hidden by it), the lamp's face on a 5-cm grid, and every
other triangle's centre of the Suzannes and spheres with its normal. Bakes evaluate their radiance at
these points with --probe, so bakes of different meshes compare (quality.py).

    python3 bench/room/probes.py ROOM.glb PROBES.csv    (writes PROBES.csv and PROBES.csv.kinds.json)
"""
import array
import collections
import json
import struct
import sys


def probes(room_glb):
    points = []  # (x, y, z, nx, ny, nz, kind)

    def grid(a, b, step):
        n = max(1, int(round((b - a) / step)))
        return [a + (i + 0.5) * (b - a) / n for i in range(n)]

    # The room is Blender's 6 x 4 x 3 m box, exported y-up: x in [-3, 3], y in [0, 3], z in [-2, 2].
    for x in grid(-3, 3, 0.1):
        for z in grid(-2, 2, 0.1):
            points.append((x, 0.0, z, 0, 1, 0, "floor"))
            if not (abs(x) < 0.65 and abs(z) < 0.45):
                points.append((x, 3.0, z, 0, -1, 0, "ceiling"))
    for y in grid(0, 3, 0.1):
        for z in grid(-2, 2, 0.1):
            points += [(-3.0, y, z, 1, 0, 0, "wall"), (3.0, y, z, -1, 0, 0, "wall")]
        for x in grid(-3, 3, 0.1):
            points += [(x, y, -2.0, 0, 0, 1, "wall"), (x, y, 2.0, 0, 0, -1, "wall")]
    for x in grid(-0.6, 0.6, 0.05):  # the lamp: 1.2 x 0.8 m at y = 2.98, facing down
        for z in grid(-0.4, 0.4, 0.05):
            points.append((x, 2.98, z, 0, -1, 0, "lamp"))

    data = open(room_glb, "rb").read()
    length = struct.unpack("<I", data[12:16])[0]
    doc = json.loads(data[20:20 + length])
    binary = 20 + length + 8

    def accessor(i):
        a = doc["accessors"][i]
        view = doc["bufferViews"][a["bufferView"]]
        width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
        values = array.array({5126: "f", 5125: "I", 5123: "H", 5121: "B"}[a["componentType"]])
        start = binary + view.get("byteOffset", 0) + a.get("byteOffset", 0)
        values.frombytes(data[start:start + a["count"] * width * values.itemsize])
        return values

    for node in doc["nodes"]:
        if "mesh" not in node:
            continue
        mesh = doc["meshes"][node["mesh"]]
        name = mesh.get("name", "")
        if not (name.startswith("Suzanne") or name.startswith("Sphere")):
            continue
        assert "rotation" not in node and "scale" not in node, "make_room.py's objects are only moved"
        t = node.get("translation", [0, 0, 0])
        for prim in mesh["primitives"]:
            p, n, idx = accessor(prim["attributes"]["POSITION"]), accessor(prim["attributes"]["NORMAL"]), accessor(prim["indices"])
            for f in range(0, len(idx) // 3, 2):
                c = [sum(p[3 * idx[3 * f + k] + a] for k in range(3)) / 3 + t[a] for a in range(3)]
                m = [sum(n[3 * idx[3 * f + k] + a] for k in range(3)) / 3 for a in range(3)]
                points.append((c[0], c[1], c[2], m[0], m[1], m[2], name.split(".")[0].lower()))
    return points


if __name__ == "__main__":
    room, out = sys.argv[1], sys.argv[2]
    pts = probes(room)
    with open(out, "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for x, y, z, nx, ny, nz, _ in pts:
            f.write("%.9g,%.9g,%.9g,%.9g,%.9g,%.9g\n" % (x, y, z, nx, ny, nz))
    json.dump([k for *_, k in pts], open(out + ".kinds.json", "w"))
    print("probes:", dict(collections.Counter(k for *_, k in pts)))
