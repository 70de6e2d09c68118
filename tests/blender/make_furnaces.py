"""Closed furnace meshes made the way users make them: Blender's own primitives, exported by
Blender's glTF exporter at its defaults (only the file name is set).

    blender -b --factory-startup --python-exit-code 1 --python make_furnaces.py -- OUT_DIR [--quick]

Furnaces: normals flipped inward and one material, base color 0.5, emission 1 (strength 1). Inside
such a closed shell every point sees only the shell, so the exact outgoing radiance is
L = L0 / (1 - rho) = 2 at every vertex. Sky objects: convex primitives as they come (outward),
base color 0.5, no emission, baked under a uniform sky of 1: every point of a lone convex object
sees only sky, so L = rho = 0.5. Trays: a cube with its top face deleted, turned off the axes (so a
crease vertex lies in the other wall's plane only to rounding), base color 1, under a sky of 1:
every ray from a white surface ends at the sky or at another white surface, so L = 1 at every
vertex, the creases included. Written per mesh: NAME.glb, and index.json listing file,
primitive, shading, sides, the exact L and the bake options it needs. Shading: flat, smooth, auto-smooth (30 deg). Sides: one
(backface culling on: Blender exports doubleSided false) and both (Blender's default: doubleSided
true).
"""
import json
import math
import os
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
out_dir = os.path.abspath(argv[0])
quick = "--quick" in argv
os.makedirs(out_dir, exist_ok=True)

ops = bpy.ops.mesh
PRIMITIVES = {
    "cube": lambda: ops.primitive_cube_add(size=2),
    "uvsphere8x4": lambda: ops.primitive_uv_sphere_add(segments=8, ring_count=4),
    "uvsphere16x8": lambda: ops.primitive_uv_sphere_add(segments=16, ring_count=8),
    "uvsphere32x16": lambda: ops.primitive_uv_sphere_add(segments=32, ring_count=16),
    "uvsphere64x32": lambda: ops.primitive_uv_sphere_add(segments=64, ring_count=32),
    "icosphere1": lambda: ops.primitive_ico_sphere_add(subdivisions=1),
    "icosphere2": lambda: ops.primitive_ico_sphere_add(subdivisions=2),
    "cylinder6": lambda: ops.primitive_cylinder_add(vertices=6),
    "cylinder32": lambda: ops.primitive_cylinder_add(vertices=32),
    "cone8": lambda: ops.primitive_cone_add(vertices=8),
    "cone32": lambda: ops.primitive_cone_add(vertices=32),
    "torus24x12": lambda: ops.primitive_torus_add(major_segments=24, minor_segments=12),
}
QUICK = ["cube", "uvsphere8x4", "uvsphere16x8", "icosphere1", "cylinder6", "cone8", "torus24x12"]
CONVEX = ["cube", "uvsphere16x8", "uvsphere32x16", "icosphere2", "cylinder32", "cone32"]
CONVEX_QUICK = ["cube", "uvsphere16x8", "cone32"]
SHADINGS = ["flat", "smooth", "autosmooth"]
SIDES = ["one", "both"]


def material(double_sided, emission, base=0.5):
    m = bpy.data.materials.new("grey_" + ("both" if double_sided else "one"))
    m.use_nodes = True
    bsdf = m.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (base, base, base, 1)
    if emission:
        bsdf.inputs["Emission"].default_value = (1, 1, 1, 1)
        bsdf.inputs["Emission Strength"].default_value = 1.0
    m.use_backface_culling = not double_sided  # how Blender's exporter decides doubleSided
    return m


def export(kind, name, shading, sides):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    PRIMITIVES[name]()
    obj = bpy.context.active_object
    if kind == "furnace":
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.flip_normals()
        bpy.ops.object.mode_set(mode="OBJECT")
    if kind == "tray":
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="DESELECT")
        bpy.ops.object.mode_set(mode="OBJECT")
        for poly in obj.data.polygons:
            poly.select = poly.normal.z > 0.5
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.delete(type="FACE")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.mesh.flip_normals()  # the inside is what a tray shows
        bpy.ops.object.mode_set(mode="OBJECT")
        obj.rotation_euler = (math.radians(20), math.radians(30), math.radians(40))
    if shading == "flat":
        bpy.ops.object.shade_flat()
    else:
        bpy.ops.object.shade_smooth()
        if shading == "autosmooth":
            obj.data.use_auto_smooth = True
            obj.data.auto_smooth_angle = math.radians(30)
    obj.data.materials.append(material(sides == "both", kind == "furnace", 1.0 if kind == "tray" else 0.5))
    file = f"{kind}_{name}_{shading}_{sides}.glb"
    bpy.ops.export_scene.gltf(filepath=os.path.join(out_dir, file))
    exact, args = {"furnace": (2.0, []), "sky": (0.5, ["--sky", "1"]), "tray": (1.0, ["--sky", "1"])}[kind]
    return {"file": file, "kind": kind, "primitive": name, "shading": shading, "sides": sides,
            "exact": exact, "args": args}


index = []
for name in (QUICK if quick else PRIMITIVES):
    for shading in SHADINGS:
        for sides in SIDES:
            index.append(export("furnace", name, shading, sides))
for name in (CONVEX_QUICK if quick else CONVEX):
    for shading in ["flat", "smooth"]:
        for sides in SIDES:
            index.append(export("sky", name, shading, sides))
for shading in ["flat", "smooth"]:
    for sides in SIDES:
        index.append(export("tray", "cube", shading, sides))

with open(os.path.join(out_dir, "index.json"), "w") as f:
    json.dump(index, f, indent=1)
print(f"make_furnaces: wrote {len(index)} meshes to {out_dir}")
