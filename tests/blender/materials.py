"""What the Blender-made scenes share (make_scene.py, bench/room/make_room.py): a Principled BSDF
material as a user sets one up, with an optional emission strength."""
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
