"""What the Blender-made scenes share (make_scene.py, bench/room/make_room.py): a Principled BSDF
material as a user sets one up, with an optional emission strength, and a room to put things in."""
import bpy


def material(name, color, emission=0.0):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (*color, 1)
    if emission:
        bsdf.inputs["Emission"].default_value = (1, 1, 1, 1)
        bsdf.inputs["Emission Strength"].default_value = emission
    return m


def inward_box(size):
    """A room: Blender's cube scaled to size = (x, y, height), standing on z = 0, the scale applied
    and the normals flipped so that its faces look inside, as a user models one."""
    bpy.ops.mesh.primitive_cube_add(size=1, location=(0, 0, size[2] / 2))
    box = bpy.context.active_object
    box.scale = size
    bpy.ops.object.transform_apply(scale=True)
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="SELECT")
    bpy.ops.mesh.flip_normals()
    bpy.ops.object.mode_set(mode="OBJECT")
    return box
