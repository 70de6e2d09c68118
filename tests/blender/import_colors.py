# Checks that Blender's own glTF importer shows a baked file's COLOR_0 vertex colors.
#
#   blender -b --factory-startup --python-exit-code 1 --python tests/blender/import_colors.py -- BAKED.glb
#
# Imports the file with bpy.ops.import_scene.gltf (default options, as a user would), then reads the
# color attribute created from COLOR_0 back from every imported mesh and compares it, corner by
# corner, with the COLOR_0 accessor read straight from the file (GLB chunks or .gltf buffers, parsed
# here with struct/json/numpy, independent of the importer).
#
# Matching: the importer may reorder, split (merge_vertices) or drop (mesh.validate) vertices and
# faces, applies node transforms to objects and turns glTF Y-up into Blender Z-up. So nothing is
# matched by index. Every glTF triangle of the scene is put in world space and Blender axes
# ((x, y, z) -> (x, -z, y)); coincident positions (within 1e-5 of the scene size) share one position id.
# Each Blender polygon, in world space through its object's matrix_world, is looked up by the
# cyclic sequence of its corners' position ids (winding kept, so the two faces of a double-sided
# pair stay apart), and each corner (loop) is compared with the glTF corner at the same position.
# Every Blender polygon must find its glTF triangle, and every non-degenerate glTF triangle with
# COLOR_0 must be found, so a dropped primitive also fails.
#
# Storage and tolerance: Blender 3.4 stores COLOR_0 as a BYTE_COLOR corner attribute: 8-bit sRGB
# (alpha 8-bit linear), clamped to [0, 1]. So the file's linear value v is encoded as the byte
# round(255 * srgb(v)) and compared with the stored byte (read exactly through `color_srgb`),
# allowing 1 code (Blender's conversion may use a fast pow approximation that can flip a rounding
# at a .5 boundary). One sRGB code is up to 2.3/255 = 0.009 in linear terms near white and far less
# in the darks. If a Blender version stores FLOAT_COLOR instead, the linear floats are compared with
# a tolerance of 1e-6 (float32 storage, no conversion). COLOR_0 outside [0, 1] is a failure: Blender
# (and the glTF spec) clamp it, so what shows would not be the file's value.
# Each checked attribute must also be the mesh's active and render (default) color attribute, and
# every material on those faces must read the render color attribute through a linked
# Color Attribute node, so the colors show in the viewport and in renders.
#
# Prints one summary line; exits 0 when every check passes, 1 otherwise.

import json
import math
import os
import struct
import sys
import time
import base64

import numpy as np

if "bool" not in np.__dict__:  # Blender 3.4's importer uses np.bool, removed in numpy 1.24
    np.bool = bool

import bpy
from mathutils.kdtree import KDTree

BYTE_TOL_CODES = 1
FLOAT_TOL = 1e-6
RANGE_SLACK = 1e-6
POS_EPS_REL = 1e-5

class Fail(Exception):
    pass


# --------------------------------------------------------------------------------------------
# glTF reading (independent of Blender's importer): the add-on's own reader, numpy only.

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "plugin", "blender"))
from radbake.gltf_file import GLTF_TO_BLENDER, GltfError, load_gltf, read_accessor, scene_mesh_nodes  # noqa: E402


def triangles(mode, n_idx):
    """Corner index triples into the index list, in Blender's importer order (glTF spec winding)."""
    if mode == 4:
        return [(i, i + 1, i + 2) for i in range(0, n_idx - 2, 3)]
    if mode == 5:
        return [(i, i + 1, i + 2) if i % 2 == 0 else (i, i + 2, i + 1) for i in range(n_idx - 2)]
    if mode == 6:
        return [(0, i, i + 1) for i in range(1, n_idx - 1)]
    return []


def gltf_corners(doc, buffers):
    """Every triangle of the scene's mesh nodes: world positions in Blender axes and corner colors.

    Returns (positions (N,3) float64, tris list of (corner position rows (3,), colors (3,4) or None,
    label, degenerate)).
    """
    pos_chunks, tris, base = [], [], 0
    for ni, world in scene_mesh_nodes(doc):
        node = doc["nodes"][ni]
        m = GLTF_TO_BLENDER @ world
        mesh = doc["meshes"][node["mesh"]]
        for pi, prim in enumerate(mesh["primitives"]):
            attrs = prim.get("attributes", {})
            mode = prim.get("mode", 4)
            if "POSITION" not in attrs or mode not in (4, 5, 6):
                continue
            p = read_accessor(doc, buffers, attrs["POSITION"])[:, :3]
            if "indices" in prim:
                idx = read_accessor(doc, buffers, prim["indices"]).reshape(-1).astype(np.int64)
            else:
                idx = np.arange(len(p))
            cols = None
            if "COLOR_0" in attrs:
                acc = doc["accessors"][attrs["COLOR_0"]]
                if acc["componentType"] not in (5126, 5121, 5123) or acc["type"] not in ("VEC3", "VEC4"):
                    raise Fail("COLOR_0 of mesh %d primitive %d is %s/%d, not a glTF color accessor"
                               % (node["mesh"], pi, acc["type"], acc["componentType"]))
                if acc["componentType"] != 5126 and not acc.get("normalized"):
                    raise Fail("COLOR_0 of mesh %d primitive %d is an integer accessor but not normalized"
                               % (node["mesh"], pi))
                c = read_accessor(doc, buffers, attrs["COLOR_0"])
                if len(c) != len(p):
                    raise Fail("COLOR_0 count %d != POSITION count %d (mesh %d primitive %d)"
                               % (len(c), len(p), node["mesh"], pi))
                cols = np.ones((len(c), 4))
                cols[:, :c.shape[1]] = c
            w = (np.c_[p, np.ones(len(p))] @ m.T)[:, :3]
            pos_chunks.append(w)
            label = "node %d (%s) mesh %d primitive %d" % (ni, node.get("name", ""), node["mesh"], pi)
            for t in triangles(mode, len(idx)):
                v = idx[list(t)]
                tris.append((base + v, None if cols is None else cols[v], label, len(set(v.tolist())) < 3))
            base += len(p)
    pos = np.concatenate(pos_chunks) if pos_chunks else np.zeros((0, 3))
    return pos, tris


# --------------------------------------------------------------------------------------------
# Colors

def srgb_encode(lin):
    lin = np.clip(lin, 0.0, 1.0)
    return np.where(lin < 0.0031308, lin * 12.92, 1.055 * np.power(lin, 1.0 / 2.4) - 0.055)


def expected_bytes(rgba):
    """The 8-bit value Blender's BYTE_COLOR should hold for linear RGBA (alpha is not sRGB-encoded)."""
    out = np.empty_like(rgba)
    out[..., :3] = srgb_encode(rgba[..., :3])
    out[..., 3] = np.clip(rgba[..., 3], 0.0, 1.0)
    return np.floor(out * 255.0 + 0.5)


def canonical(seq):
    """The rotation of a cyclic sequence that is smallest; returns (tuple, offset)."""
    n = len(seq)
    best = min(range(n), key=lambda k: tuple(seq[k:] + seq[:k]))
    return tuple(seq[best:] + seq[:best]), best


def color_attribute_of(mesh):
    """The color attribute the importer made from COLOR_0 (named 'Col' in 3.4, 'Color' later)."""
    ca = mesh.color_attributes
    for name in ("Col", "Color", "COLOR_0"):
        if name in ca:
            return ca[name]
    return ca[0] if len(ca) else None


def render_color_name(ca):
    name = getattr(ca, "default_color_name", None)
    if name is not None:
        return name
    i = ca.render_color_index
    lst = list(ca)
    return lst[i].name if 0 <= i < len(lst) else None


def material_reads_colors(mat, attr_name):
    if mat is None or not mat.use_nodes or mat.node_tree is None:
        return False
    for node in mat.node_tree.nodes:
        if node.bl_idname == "ShaderNodeVertexColor" and node.layer_name in ("", attr_name):
            if any(s.is_linked for s in node.outputs):
                return True
    return False


# --------------------------------------------------------------------------------------------

def run(path):
    t0 = time.time()
    doc, buffers = load_gltf(path)
    pos, tris = gltf_corners(doc, buffers)
    n_color_tris = sum(1 for t in tris if t[1] is not None)
    if n_color_tris == 0:
        raise Fail("%s has no triangle primitive with COLOR_0" % path)
    for _rows, cols, label, _deg in tris:
        if cols is not None and (cols.min() < -RANGE_SLACK or cols.max() > 1 + RANGE_SLACK):
            raise Fail("%s: COLOR_0 outside [0, 1] (%g..%g): Blender clamps it"
                       % (label, cols.min(), cols.max()))

    # Position ids: glTF world positions (Blender axes) welded within eps.
    extent = float(np.max(np.ptp(pos, axis=0))) if len(pos) else 1.0
    eps = POS_EPS_REL * max(extent, 1e-9)
    kd = KDTree(len(pos))
    for i, p in enumerate(pos):
        kd.insert(p, i)
    kd.balance()
    pid = np.full(len(pos), -1, dtype=np.int64)
    for i, p in enumerate(pos):
        if pid[i] < 0:
            for _co, j, _d in kd.find_range(p, eps):
                if pid[j] < 0:
                    pid[j] = i

    lookup = {}
    for ti, (rows, _cols, _label, _deg) in enumerate(tris):
        key, off = canonical(pid[rows].tolist())
        lookup.setdefault(key, []).append((ti, off))
    used = np.zeros(len(tris), dtype=bool)

    # Import exactly as a user would (default options).
    bpy.ops.wm.read_factory_settings(use_empty=True)
    t1 = time.time()
    res = bpy.ops.import_scene.gltf(filepath=path)
    t_import = time.time() - t1
    if res != {"FINISHED"}:
        raise Fail("import_scene.gltf returned %s" % res)
    bpy.context.view_layer.update()

    errors = []
    stats = dict(meshes=0, colored=0, loops=0, max_code=0.0, max_lin=0.0, storage=set(), ambiguous=0)

    def err(msg):
        if len(errors) < 20:
            errors.append(msg)
        else:
            errors.append(None)

    for ob in bpy.context.scene.objects:
        if ob.type != "MESH":
            continue
        stats["meshes"] += 1
        me = ob.data
        nv, nl = len(me.vertices), len(me.loops)
        co = np.empty(nv * 3, dtype=np.float32)
        me.vertices.foreach_get("co", co)
        mw = np.array(ob.matrix_world, dtype=np.float64)
        wco = (np.c_[co.reshape(-1, 3).astype(np.float64), np.ones(nv)] @ mw.T)[:, :3]
        vpid = np.empty(nv, dtype=np.int64)
        for v in range(nv):
            _c, j, d = kd.find(wco[v])
            if j is None or d > eps:
                err("%s: vertex %d at %s is at no glTF position (nearest %.3g away)"
                    % (ob.name, v, tuple(np.round(wco[v], 5)), -1 if d is None else d))
                vpid[v] = -1
            else:
                vpid[v] = pid[j]
        loop_v = np.empty(nl, dtype=np.int64)
        me.loops.foreach_get("vertex_index", loop_v)

        attr = color_attribute_of(me)
        linear = byte = None
        if attr is not None:
            stats["storage"].add("%s/%s" % (attr.data_type, attr.domain))
            n = len(attr.data)
            buf = np.empty(n * 4, dtype=np.float32)
            attr.data.foreach_get("color", buf)
            linear = buf.reshape(-1, 4).astype(np.float64)
            if attr.data_type == "BYTE_COLOR":
                attr.data.foreach_get("color_srgb", buf)
                byte = np.floor(buf.reshape(-1, 4).astype(np.float64) * 255.0 + 0.5)
            elif attr.data_type != "FLOAT_COLOR":
                err("%s: color attribute %s has type %s" % (ob.name, attr.name, attr.data_type))
                attr = None

        def value_index(loop):
            return loop if attr.domain == "CORNER" else loop_v[loop]

        obj_has_color = False
        for poly in me.polygons:
            ls = list(range(poly.loop_start, poly.loop_start + poly.loop_total))
            key, off = canonical([int(vpid[loop_v[l]]) for l in ls])
            ls = ls[off:] + ls[:off]
            cands = [(ti, o) for ti, o in lookup.get(key, ())]
            if not cands:
                err("%s: polygon %d (vertices %s) matches no glTF triangle"
                    % (ob.name, poly.index, [int(loop_v[l]) for l in ls]))
                continue
            best = None
            for ti, o in cands:
                rows, cols, label, _deg = tris[ti]
                # A face without COLOR_0 in a mesh with colors is filled white by the importer.
                exp = np.roll(cols if cols is not None else np.ones((len(rows), 4)), -o, axis=0)
                if attr is None:
                    score, dc, dl, got, want = (0.0 if cols is None else math.inf), 0.0, 0.0, None, None
                else:
                    vi = [value_index(l) for l in ls]
                    dl = float(np.max(np.abs(linear[vi] - np.clip(exp, 0, 1))))
                    if byte is not None:
                        got, want = byte[vi], expected_bytes(exp)
                        dc = float(np.max(np.abs(got - want)))
                        score = dc
                    else:
                        got, want, dc = linear[vi], exp, 0.0
                        score = dl
                cand = (bool(used[ti]), score, ti, dc, dl, cols is not None, label, got, want)
                if best is None or cand[:2] < best[:2]:
                    best = cand
            if len(cands) > 1:
                stats["ambiguous"] += 1
            _was_used, _score, ti, dc, dl, has_col, label, got, want = best
            used[ti] = True
            if attr is None:
                if has_col:
                    err("%s: no color attribute, but its faces come from %s, which has COLOR_0"
                        % (ob.name, label))
                continue
            obj_has_color = obj_has_color or has_col
            stats["loops"] += len(ls)
            stats["max_code"] = max(stats["max_code"], dc)
            stats["max_lin"] = max(stats["max_lin"], dl)
            if (dc > BYTE_TOL_CODES) if byte is not None else (dl > FLOAT_TOL):
                err("%s: polygon %d from %s: Blender %s, file %s (%s; diff %g codes, %g linear)"
                    % (ob.name, poly.index, label, np.round(got, 5).tolist(), np.round(want, 5).tolist(),
                       "8-bit sRGB" if byte is not None else "linear", dc, dl))

        if attr is not None and obj_has_color:
            stats["colored"] += 1
            ca = me.color_attributes
            active = ca.active_color.name if ca.active_color is not None else None
            render = render_color_name(ca)
            if active != attr.name:
                err("%s: active color attribute is %r, not %r" % (ob.name, active, attr.name))
            if render != attr.name:
                err("%s: render color attribute is %r, not %r" % (ob.name, render, attr.name))
            mat_idx = np.empty(len(me.polygons), dtype=np.int64)
            me.polygons.foreach_get("material_index", mat_idx)
            for mi in sorted(set(mat_idx.tolist())):
                mat = me.materials[mi] if mi < len(me.materials) else None
                if mat is not None and not material_reads_colors(mat, attr.name):
                    err("%s: material %r has no linked Color Attribute node for %r"
                        % (ob.name, mat.name, attr.name))

    missing = [t for ti, t in enumerate(tris) if not used[ti] and t[1] is not None and not t[3]]
    if missing:
        err("%d glTF triangles with COLOR_0 have no Blender polygon (first: %s)"
            % (len(missing), missing[0][2]))
    if stats["colored"] == 0:
        err("no imported mesh carries COLOR_0")

    storage = ",".join(sorted(stats["storage"])) or "none"
    tol = ("%d sRGB code" % BYTE_TOL_CODES) if "BYTE" in storage else ("%g linear" % FLOAT_TOL)
    ok = not errors
    print("blender_import_colors: %s: %s: %d meshes (%d with COLOR_0), %d corners compared "
          "(%d ambiguous faces), storage %s, max |diff| %g sRGB codes / %.6f linear, tolerance %s, "
          "import %.2f s, total %.2f s"
          % ("OK" if ok else "FAIL", os.path.basename(path), stats["meshes"], stats["colored"],
             stats["loops"], stats["ambiguous"], storage, stats["max_code"], stats["max_lin"], tol,
             t_import, time.time() - t0))
    for e in errors:
        print("  error: %s" % e if e is not None else "  error: (more errors not shown)")
        if e is None:
            break
    return ok


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    if len(argv) != 1:
        print("usage: blender -b --factory-startup --python-exit-code 1 --python import_colors.py -- BAKED.glb")
        sys.exit(2)
    try:
        ok = run(os.path.abspath(argv[0]))
    except (Fail, GltfError) as e:
        print("blender_import_colors: FAIL: %s: %s" % (os.path.basename(argv[0]), e))
        ok = False
    sys.stdout.flush()
    sys.exit(0 if ok else 1)


main()
