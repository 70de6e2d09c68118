"""The room of issue 16, made in Blender the way a user makes one and exported by Blender's glTF
exporter at its defaults: six walls (a cube with its normals flipped), an emissive ceiling panel,
two Suzannes with a Subdivision Surface modifier and two UV spheres standing on the floor, Blender's
default (double-sided) materials. At LEVEL 1 and 64x32 spheres it has the issue's 8,039 faces
(15,822 triangles); higher levels make it larger for scaling runs. SHADING `flat` (Blender's
default for its primitives: a vertex per face around each point) or `smooth` (Shade Smooth on the
Suzannes and spheres, as a user does to a subdivided object: one vertex per point).

    blender -b --factory-startup --python-exit-code 1 --python make_room.py -- OUT.glb [LEVEL [SEGMENTS [SHADING]]]
"""
import os
import sys

import bpy

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "tests", "blender"))
from materials import inward_box, material  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:]
out = args[0]
level = int(args[1]) if len(args) > 1 else 1
segments = int(args[2]) if len(args) > 2 else 64
shading = args[3] if len(args) > 3 else "flat"
if shading not in ("flat", "smooth"):
    sys.exit("make_room.py: SHADING must be flat or smooth, not %r" % shading)
bpy.ops.wm.read_factory_settings(use_empty=True)


def assign(obj, mat):
    obj.data.materials.clear()
    obj.data.materials.append(mat)


# The room: a 6 m x 3 m x 4 m box seen from inside.
room = inward_box((6, 4, 3))
assign(room, material("walls", (0.7, 0.7, 0.7)))

# The ceiling light: a panel just below the ceiling, facing down.
bpy.ops.mesh.primitive_plane_add(size=1, location=(0, 0, 2.98))
panel = bpy.context.object
panel.scale = (1.2, 0.8, 1)
panel.rotation_euler = (3.14159265, 0, 0)
bpy.ops.object.transform_apply(scale=True, rotation=True)
assign(panel, material("light", (0.8, 0.8, 0.8), emission=10.0))

# Two Suzannes (Subdivision Surface, applied) and two UV spheres on the floor.
for i, x in enumerate((-1.5, 1.5)):
    bpy.ops.mesh.primitive_monkey_add(size=1, location=(x, -0.5, 0.5))
    monkey = bpy.context.object
    if level > 0:  # level 0: the plain Suzanne (500 faces), for quick comparisons with exact
        mod = monkey.modifiers.new("subdivision", "SUBSURF")
        mod.levels = level
        mod.render_levels = level
        bpy.ops.object.modifier_apply(modifier=mod.name)
    assign(monkey, material("suzanne %d" % i, (0.8, 0.3 + 0.4 * i, 0.2)))
    if shading == "smooth":
        bpy.ops.object.shade_smooth()
    bpy.ops.mesh.primitive_uv_sphere_add(segments=segments, ring_count=segments // 2, radius=0.5, location=(x, 1.0, 0.5))
    assign(bpy.context.object, material("sphere %d" % i, (0.2, 0.4, 0.8)))
    if shading == "smooth":
        bpy.ops.object.shade_smooth()

bpy.ops.export_scene.gltf(filepath=out)
faces = sum(len(o.data.polygons) for o in bpy.data.objects if o.type == "MESH")
print("room: %d faces" % faces)
