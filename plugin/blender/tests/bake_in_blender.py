# Headless tests of the add-on inside Blender (run by plugin/blender/tests/run_blender_tests.sh):
#
#   BLENDER_USER_SCRIPTS=DIR blender -b --factory-startup --python-exit-code 1 \
#       --python plugin/blender/tests/bake_in_blender.py -- RADBAKE REPO_ROOT
#
# 1. The bundled Cornell box, imported into an empty scene, baked with the add-on's operator (the
#    same call as from Blender's command line): every mesh gets a FLOAT_COLOR point attribute, active
#    and render, holding at each vertex the _RADIANCE that radbake wrote for that place in the same
#    run (the baked .glb kept with keep_path), and bright under the light, dark in the blocks' shade.
# 2. A bake that fails (radbake given a bad option): the operator reports radbake's own message and
#    the scene is exactly as before.
# 3. The lightmap output: a UV map on every object whose corners read the lightmap texel holding
#    that corner's light.

import os
import sys

import addon_utils
import bpy
import numpy as np

if "bool" not in np.__dict__:  # Blender 3.4's glTF importer uses np.bool (gone in numpy 1.24)
    np.bool = bool

radbake_binary, repo = sys.argv[sys.argv.index("--") + 1:][:2]
sys.path.insert(0, os.path.join(repo, "plugin", "blender"))
from radbake import gltf_file  # noqa: E402  (the add-on's own reader of radbake's output)

failures = []


def check(condition, message):
    if not condition:
        failures.append(message)
        print("FAIL: " + message, flush=True)


def load_cornell():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    addon_utils.enable("radbake", default_set=True, persistent=True)
    bpy.context.preferences.addons["radbake"].preferences.executable = radbake_binary
    bpy.ops.import_scene.gltf(filepath=os.path.join(repo, "examples", "cornell_box.gltf"))
    return [o for o in bpy.context.scene.objects if o.type == 'MESH']


def snapshot():
    """What a failed bake must not change: objects, their meshes, attributes, UV maps, selection."""
    out = []
    for o in sorted(bpy.context.scene.objects, key=lambda o: o.name):
        me = o.data if o.type == 'MESH' else None
        out.append((o.name, o.select_get(), tuple(o.matrix_world.col[3]),
                    None if me is None else (len(me.vertices), len(me.polygons),
                                             tuple(a.name for a in me.attributes),
                                             tuple(u.name for u in me.uv_layers))))
    return out, sorted(m.name for m in bpy.data.materials), sorted(i.name for i in bpy.data.images)


def baked_file_vertices(path):
    """{node name: baked vertices}: each Blender object is compared with its own node (the light sits
    in the ceiling's hole, so their corners coincide)."""
    doc, buffers = gltf_file.load_gltf(path)
    return {doc["nodes"][ni].get("name"): gltf_file.baked_vertices(doc, buffers, ni, world)
            for ni, world in gltf_file.scene_mesh_nodes(doc)}


# ---- 1. vertex colors, refined adaptively (the lightmap below is uniform: both paths of the panel)
objects = load_cornell()
tmp = os.environ.get("RADBAKE_TEST_TMP", "/tmp")
kept = os.path.join(tmp, "cornell_blender.glb")
settings = bpy.context.scene.radbake
settings.refine = 'ADAPTIVE'
settings.refine_target = 0.05
settings.max_patches = 1500
settings.keep_path = kept
result = bpy.ops.radbake.bake()
check(result == {'FINISHED'}, "the bake finished: %s" % result)
baked = baked_file_vertices(kept)
compared, worst, luminance = 0, 0.0, []
for obj in objects:
    check(obj.name in baked, "%s is a node of the baked file" % obj.name)
    if obj.name not in baked:
        continue
    positions, radiance, normals = (baked[obj.name][k] for k in ("positions", "radiance", "normals"))
    eps = 1e-5 * max(np.ptp(positions, axis=0).max(), 1e-3)
    me = obj.data
    attribute = me.color_attributes.get("radbake")
    check(attribute is not None, "%s has the radbake color attribute" % obj.name)
    if attribute is None:
        continue
    check(attribute.data_type == 'FLOAT_COLOR' and attribute.domain == 'POINT', "%s: float, per point" % obj.name)
    check(me.color_attributes.active_color_name == "radbake", "%s: active color" % obj.name)
    check(me.color_attributes[me.color_attributes.render_color_index].name == "radbake", "%s: render color" % obj.name)
    colors = np.zeros(len(me.vertices) * 4, dtype=np.float32)
    attribute.data.foreach_get("color", colors)
    colors = colors.reshape(-1, 4)
    for v in me.vertices:
        world = np.array(obj.matrix_world @ v.co)
        n = np.array((obj.matrix_world.to_3x3().inverted().transposed() @ v.normal).normalized())
        near = np.where(np.abs(positions - world).max(axis=1) < eps)[0]
        near = [i for i in near if np.dot(normals[i], n) > 0.5] or list(near)
        check(len(near) > 0, "%s vertex %d has a baked twin" % (obj.name, v.index))
        if near:
            expected = radiance[near].mean(axis=0)
            worst = max(worst, float(np.abs(colors[v.index, :3] - expected).max() / max(expected.max(), 1e-6)))
            compared += 1
            luminance.append(float(expected @ [0.2126, 0.7152, 0.0722]))
check(compared >= 60, "compared %d vertices" % compared)
check(worst < 1e-6, "color attribute = the CLI's _RADIANCE (worst relative difference %.2e)" % worst)
check(max(luminance) > 10 and min(luminance) < 0.1, "light and shade: %.3g .. %.3g" % (min(luminance), max(luminance)))
print("radbake add-on: %d vertices of %d objects match _RADIANCE (worst %.1e)" % (compared, len(objects), worst))
bpy.ops.wm.save_as_mainfile(filepath=os.path.join(tmp, "cornell_baked.blend"))

# ---- 2. a failing bake leaves the scene as it was and reports radbake's message
objects = load_cornell()
from radbake import command  # noqa: E402
build = command.build_command
command.build_command = lambda *a, **k: build(*a, **k) + ["--threads", "0"]  # radbake refuses this
before = snapshot()
reports = []
try:
    bpy.ops.radbake.bake()
except RuntimeError as e:  # operator ERROR reports surface as RuntimeError in background mode
    reports.append(str(e))
command.build_command = build
check(any("--threads" in r for r in reports), "the error carries radbake's message: %s" % reports)
check(snapshot() == before, "the scene is unchanged after a failed bake")
check(not bpy.context.window_manager.radbake_state.is_baking, "no bake left running")

# ---- 3. lightmap: the second UV map reads each corner's own light
objects = load_cornell()
settings = bpy.context.scene.radbake
settings.refine = 'SUBDIVIDE'
settings.subdivide = 4
settings.output = 'LIGHTMAP'
settings.lightmap_size = 256
settings.keep_path = os.path.join(tmp, "cornell_lightmap.glb")
check(bpy.ops.radbake.bake() == {'FINISHED'}, "the lightmap bake finished")
image = bpy.data.images.get("radbake lightmap")
check(image is not None and image.size[0] > 0, "the lightmap image is loaded")
baked = baked_file_vertices(settings.keep_path)
if image is not None:
    w, h = image.size
    corners, density = 0, []
    for obj in objects:
        me = obj.data
        layer = me.uv_layers.get("radbake")
        check(layer is not None, "%s has the lightmap UV map" % obj.name)
        if layer is None:
            continue
        b = baked[obj.name]
        check(b["uv1"] is not None, "%s reads the lightmap in the file" % obj.name)
        uv = np.zeros(len(me.loops) * 2, dtype=np.float32)
        layer.data.foreach_get("uv", uv)
        uv = uv.reshape(-1, 2)
        eps = 1e-5 * max(np.ptp(b["positions"], axis=0).max(), 1e-3)
        normal_matrix = obj.matrix_world.to_3x3().inverted().transposed()
        for polygon in me.polygons:
            n = np.array((normal_matrix @ polygon.normal).normalized())
            corner_uv, corner_xyz = [], []
            for li in polygon.loop_indices:
                p = np.array(obj.matrix_world @ me.vertices[me.loops[li].vertex_index].co)
                near = np.where(np.abs(b["positions"] - p).max(axis=1) < eps)[0]
                facing = [i for i in near if np.dot(b["normals"][i], n) > 0.99]
                # The corner reads a UV the file gives a vertex of this face's plane at this place.
                mine = np.array([uv[li][0], 1 - uv[li][1]])
                check(any(np.abs(b["uv1"][i] - mine).max() < 1e-6 for i in facing),
                      "%s corner %d reads a UV of the file" % (obj.name, li))
                x, y = uv[li] * (w, h) - 0.5
                check(abs(x - round(x)) < 1e-3 and abs(y - round(y)) < 1e-3, "corner UV on a texel center")
                corner_uv.append(uv[li] * (w, h))
                corner_xyz.append(p)
                corners += 1
            # All corners from one chart: the face keeps its shape in texels (one texel size
            # everywhere, up to the half-texel snapping of its corners).
            a3 = 0.5 * np.linalg.norm(np.cross(corner_xyz[1] - corner_xyz[0], corner_xyz[2] - corner_xyz[0]))
            a2 = 0.5 * abs(np.cross(corner_uv[1] - corner_uv[0], corner_uv[2] - corner_uv[0]))
            if a3 > 0:
                density.append(a2 / a3)
    spread = (max(density) / min(density)) if density else float("inf")
    check(corners > 100 and spread < 1.15, "%d corners; texels per area spread %.3f" % (corners, spread))
    print("radbake add-on: lightmap UVs on %d corners, texel density spread %.3f" % (corners, spread))


if failures:
    print("%d failure(s)" % len(failures))
    sys.exit(1)
print("radbake add-on: all checks passed")
