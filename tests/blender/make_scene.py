"""A small room made in Blender the way a user makes one, exported by Blender's glTF exporter with
its defaults plus "Punctual Lights" ticked:

- a closed room (a cube with its normals flipped), Blender's default double-sided materials;
- a crate with a Bevel modifier, applied, then placed three times as linked duplicates (one mesh,
  three nodes: instancing);
- a Suzanne with a Subdivision Surface modifier, applied, and a second UV map (TEXCOORD_1);
- a point light, a spot light and a sun (KHR_lights_punctual), and an emissive ceiling panel.

    blender -b --factory-startup --python-exit-code 1 --python make_scene.py -- OUT.glb
"""
import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from materials import inward_box, material  # noqa: E402

out = sys.argv[sys.argv.index("--") + 1]
bpy.ops.wm.read_factory_settings(use_empty=True)


# The room: 6 × 6 × 3, normals inward.
room = inward_box((6, 6, 3))
room.name = "Room"
room.data.materials.append(material("Walls", (0.7, 0.7, 0.7)))

# A bevelled crate, the modifier applied, then three linked duplicates.
bpy.ops.mesh.primitive_cube_add(size=0.8, location=(-1.5, -1.5, 0.4))
crate = bpy.context.active_object
crate.name = "Crate"
bevel = crate.modifiers.new("Bevel", "BEVEL")
bevel.width = 0.05
bpy.ops.object.modifier_apply(modifier=bevel.name)
crate.data.materials.append(material("Wood", (0.6, 0.4, 0.2)))
for i, (x, y) in enumerate([(1.5, -1.5), (-1.5, 1.5)]):
    bpy.ops.object.duplicate_move_linked(TRANSFORM_OT_translate={"value": (x + 1.5, y + 1.5, 0)})
    bpy.context.active_object.rotation_euler[2] = math.radians(20 * (i + 1))
    bpy.ops.object.select_all(action="DESELECT")
    crate.select_set(True)
    bpy.context.view_layer.objects.active = crate

# Suzanne, subdivided once (applied), with a second UV map.
bpy.ops.mesh.primitive_monkey_add(size=1, location=(1.2, 1.2, 0.8))
monkey = bpy.context.active_object
monkey.name = "Suzanne"
subsurf = monkey.modifiers.new("Subdivision", "SUBSURF")
subsurf.levels = 1
bpy.ops.object.modifier_apply(modifier=subsurf.name)
bpy.ops.object.shade_smooth()
monkey.data.uv_layers.new(name="Lightmap")
monkey.data.materials.append(material("Clay", (0.8, 0.5, 0.4)))

# An emissive panel just below the ceiling, facing down.
bpy.ops.mesh.primitive_plane_add(size=1, location=(0, 0, 2.95))
panel = bpy.context.active_object
panel.name = "Panel"
panel.rotation_euler[0] = math.pi
panel.data.materials.append(material("Glow", (0.8, 0.8, 0.8), emission=5.0))

# Lights.
bpy.ops.object.light_add(type="POINT", location=(2, -2, 2.2))
bpy.context.active_object.data.energy = 200
bpy.ops.object.light_add(type="SPOT", location=(-2, 2, 2.5), rotation=(0.3, 0, 0))
bpy.context.active_object.data.energy = 300
bpy.ops.object.light_add(type="SUN", location=(0, 0, 2.8), rotation=(0.2, 0.1, 0))
bpy.context.active_object.data.energy = 2

bpy.ops.export_scene.gltf(filepath=out, export_lights=True)
print(f"make_scene: wrote {out}")
