#!/usr/bin/env python3
"""A closed unit room (the cube [0,1]^3 seen from inside, rho 0.5, one quad a face, each face its own
four vertices as Blender exports a cube) lit by a double-sided lamp (0.2 x 0.2, rho 0.5, L0 1) 2 cm
under its ceiling, as a glTF with its buffer embedded: the scene where the hierarchical transport's
links, judged by area alone, missed the ceiling spot the lamp hides from the walls (docs/results.md,
second session of 2026-12-03) until they were refined by their light (docs/radiosity.md, "Refinement
by light"). The same scene as lampRoomGltf() in tests/cli_test.cpp.

  lamp_room.py OUT.gltf
"""
import base64, json, struct, sys

# Per face: origin and two edges whose cross product is the inward normal.
FACES = [((0, 0, 0), (0, 0, 1), (1, 0, 0)), ((0, 1, 0), (1, 0, 0), (0, 0, 1)), ((0, 0, 0), (0, 1, 0), (0, 0, 1)),
         ((1, 0, 0), (0, 0, 1), (0, 1, 0)), ((0, 0, 0), (1, 0, 0), (0, 1, 0)), ((0, 0, 1), (0, 1, 0), (1, 0, 0))]
points = []
for o, u, v in FACES:
    corner = [o, [o[i] + u[i] for i in range(3)], [o[i] + u[i] + v[i] for i in range(3)], [o[i] + v[i] for i in range(3)]]
    points += [corner[k] for k in (0, 1, 2, 0, 2, 3)]
lamp = [[0.4, 0.98, 0.4], [0.4, 0.98, 0.6], [0.6, 0.98, 0.6], [0.6, 0.98, 0.4]]  # facing down
points += [lamp[k] for k in (0, 1, 2, 0, 2, 3)]
data = struct.pack("<%df" % (3 * len(points)), *[c for p in points for c in p])
grey = {"baseColorFactor": [0.5, 0.5, 0.5, 1], "metallicFactor": 0}
doc = {
    "asset": {"version": "2.0", "generator": "radbake bench/hierarchical/lamp_room.py"},
    "scene": 0, "scenes": [{"nodes": [0, 1]}],
    "nodes": [{"name": "room", "mesh": 0}, {"name": "lamp", "mesh": 1}],
    "meshes": [{"name": "room", "primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
               {"name": "lamp", "primitives": [{"attributes": {"POSITION": 1}, "material": 1}]}],
    "materials": [{"name": "wall", "pbrMetallicRoughness": grey},
                  {"name": "lamp", "pbrMetallicRoughness": grey, "emissiveFactor": [1, 1, 1], "doubleSided": True}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 36, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]},
                  {"bufferView": 0, "byteOffset": 432, "componentType": 5126, "count": 6, "type": "VEC3",
                   "min": [0.4, 0.98, 0.4], "max": [0.6, 0.98, 0.6]}],
    "bufferViews": [{"buffer": 0, "byteLength": len(data)}],
    "buffers": [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
}
with open(sys.argv[1], "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
