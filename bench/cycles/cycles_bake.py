"""Cycles bake of per-vertex outgoing radiance (Blender 3.4, headless), after the team's Blender notes
(blender.md, kept beside the repository, not in it).

blender -b --factory-startup --python-exit-code 1 --python cycles_bake.py -- IN.gltf OUT.npz --samples N [--seed S]

Materials are rewired to Diffuse BSDF (same base color) + Emission (same color x strength, front side
only, as radbake's one-sided emitters), world black, 64 diffuse bounces, no clamping, no denoising,
no adaptive sampling, light threshold 0. COMBINED bake with every pass into a POINT-domain
FLOAT_COLOR attribute (each corner is sampled at its vertex; the corners of a vertex are averaged).
OUT.npz: pos, nrm (glTF world space), L (linear RGB), and the bake call's wall and CPU time.
"""
import sys, time, json
import numpy as np
if "bool" not in np.__dict__:   # Debian numpy 1.24 vs the 3.4 glTF importer
    np.bool = bool
import bpy

argv = sys.argv[sys.argv.index("--") + 1:]
src, out = argv[0], argv[1]
opt = dict(zip(argv[2::2], argv[3::2]))
samples = int(opt.get("--samples", 64)); seed = int(opt.get("--seed", 0))

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
bpy.ops.import_scene.gltf(filepath=src, merge_vertices=False, import_shading='NORMALS',
                          convert_lighting_mode='COMPAT')

# Lambertian materials: Diffuse BSDF + front-side Emission
for mat in bpy.data.materials:
    if not mat.use_nodes:
        continue
    nt = mat.node_tree
    pr = next((n for n in nt.nodes if n.type == 'BSDF_PRINCIPLED'), None)
    outn = next((n for n in nt.nodes if n.type == 'OUTPUT_MATERIAL'), None)
    if pr is None or outn is None:
        continue
    dif = nt.nodes.new('ShaderNodeBsdfDiffuse'); dif.inputs['Roughness'].default_value = 0.0
    bc = pr.inputs['Base Color']
    if bc.is_linked:
        nt.links.new(bc.links[0].from_socket, dif.inputs['Color'])
    else:
        dif.inputs['Color'].default_value = bc.default_value
    em = nt.nodes.new('ShaderNodeEmission')
    ec = pr.inputs['Emission']
    if ec.is_linked:
        nt.links.new(ec.links[0].from_socket, em.inputs['Color'])
    else:
        em.inputs['Color'].default_value = ec.default_value
    em.inputs['Strength'].default_value = pr.inputs['Emission Strength'].default_value
    geo = nt.nodes.new('ShaderNodeNewGeometry')
    mix = nt.nodes.new('ShaderNodeMixShader')           # fac = backfacing: front -> emission, back -> black
    nt.links.new(geo.outputs['Backfacing'], mix.inputs['Fac'])
    nt.links.new(em.outputs['Emission'], mix.inputs[1])
    add = nt.nodes.new('ShaderNodeAddShader')
    nt.links.new(dif.outputs['BSDF'], add.inputs[0]); nt.links.new(mix.outputs['Shader'], add.inputs[1])
    nt.links.new(add.outputs['Shader'], outn.inputs['Surface'])

world = bpy.data.worlds.new("black"); world.use_nodes = True
world.node_tree.nodes['Background'].inputs['Strength'].default_value = 0.0
scene.world = world

scene.render.engine = 'CYCLES'
c = scene.cycles
c.device = 'CPU'; c.samples = samples; c.seed = seed
c.use_adaptive_sampling = False; c.use_denoising = False
c.max_bounces = c.diffuse_bounces = 64
c.glossy_bounces = c.transmission_bounces = c.volume_bounces = c.transparent_max_bounces = 64
c.sample_clamp_direct = 0.0; c.sample_clamp_indirect = 0.0
c.light_sampling_threshold = 0.0
c.caustics_reflective = c.caustics_refractive = True
c.use_auto_tile = False

meshes = [o for o in scene.objects if o.type == 'MESH']
bpy.ops.object.select_all(action='DESELECT')
for o in meshes:
    if o.data.users > 1:
        o.data = o.data.copy()
    attr = o.data.color_attributes.new("cycles_bake", 'FLOAT_COLOR', 'POINT')
    o.data.color_attributes.active_color = attr
    o.select_set(True)
bpy.context.view_layer.objects.active = meshes[0]

t0 = time.perf_counter(); c0 = time.process_time()
bpy.ops.object.bake(type='COMBINED', target='VERTEX_COLORS', use_clear=True,
                    pass_filter={'EMIT', 'DIRECT', 'INDIRECT', 'DIFFUSE', 'GLOSSY', 'TRANSMISSION'})
bake_wall = time.perf_counter() - t0; bake_cpu = time.process_time() - c0

pos, nrm, L, obj = [], [], [], []
for o in meshes:
    me = o.data; n = len(me.vertices)
    col = np.empty(4 * n, np.float32); me.color_attributes["cycles_bake"].data.foreach_get("color", col)
    co = np.empty(3 * n, np.float32); me.vertices.foreach_get("co", co)
    no = np.empty(3 * n, np.float32); me.vertices.foreach_get("normal", no)
    mw = np.array(o.matrix_world); co = co.reshape(-1, 3) @ mw[:3, :3].T + mw[:3, 3]
    no = no.reshape(-1, 3) @ np.linalg.inv(mw[:3, :3]); no /= np.linalg.norm(no, axis=1, keepdims=True)
    # Blender Z-up -> glTF Y-up: (x, y, z)_glTF = (x, z, -y)_Blender
    pos.append(np.c_[co[:, 0], co[:, 2], -co[:, 1]]); nrm.append(np.c_[no[:, 0], no[:, 2], -no[:, 1]])
    L.append(col.reshape(-1, 4)[:, :3]); obj += [o.name] * n
np.savez(out, pos=np.concatenate(pos), nrm=np.concatenate(nrm), L=np.concatenate(L), obj=np.array(obj),
         bake_wall=bake_wall, bake_cpu=bake_cpu, samples=samples, seed=seed,
         blender=bpy.app.version_string, threads=scene.render.threads)
print(json.dumps({"samples": samples, "seed": seed, "bake_wall": bake_wall, "bake_cpu": bake_cpu,
                  "vertices": int(sum(len(p) for p in pos))}))
