# Reading a glTF file (.glb or .gltf) with numpy: the add-on reads radbake's output itself, so the
# exact _RADIANCE reaches Blender (its glTF importer drops custom attributes and stores COLOR_0 as
# 8-bit sRGB). No bpy here: the tests load this module without Blender.

import base64
import json
import os
import struct
from urllib.parse import unquote

import numpy as np

COMPONENT = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
NCOMP = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}

# glTF is Y-up, Blender Z-up: (x, y, z)_glTF -> (x, -z, y)_Blender.
GLTF_TO_BLENDER = np.array([[1, 0, 0, 0], [0, 0, -1, 0], [0, 1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)


class GltfError(Exception):
    pass


def load_gltf(path):
    """(document, [buffer bytes]) of a .glb or .gltf (data URIs or files beside it)."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        _magic, _version, length = struct.unpack_from("<III", data, 0)
        off, doc, bin_chunk = 12, None, None
        while off + 8 <= min(length, len(data)):
            clen, ctype = struct.unpack_from("<II", data, off)
            chunk = data[off + 8:off + 8 + clen]
            if ctype == 0x4E4F534A:  # JSON
                doc = json.loads(chunk.decode("utf-8"))
            elif ctype == 0x004E4942 and bin_chunk is None:  # BIN
                bin_chunk = chunk
            off += 8 + clen
        if doc is None:
            raise GltfError("%s: GLB without a JSON chunk" % path)
    else:
        doc, bin_chunk = json.loads(data.decode("utf-8")), None
    buffers = []
    for i, b in enumerate(doc.get("buffers", [])):
        uri = b.get("uri")
        if uri is None:
            if bin_chunk is None:
                raise GltfError("%s: buffer %d has no uri and there is no BIN chunk" % (path, i))
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), unquote(uri)), "rb") as f:
                buffers.append(f.read())
    return doc, buffers


def _view_array(doc, buffers, view_index, byte_offset, dtype, ncomp, count):
    bv = doc["bufferViews"][view_index]
    buf = buffers[bv["buffer"]]
    itemsize = np.dtype(dtype).itemsize
    stride = bv.get("byteStride") or itemsize * ncomp
    start = bv.get("byteOffset", 0) + byte_offset
    if count and start + stride * (count - 1) + itemsize * ncomp > len(buf):
        raise GltfError("accessor reads past the end of buffer %d" % bv["buffer"])
    return np.ndarray(shape=(count, ncomp), dtype=dtype, buffer=buf, offset=start,
                      strides=(stride, itemsize)).copy()


def read_accessor(doc, buffers, index):
    """Accessor values as float64 (normalized integers mapped to [0, 1] / [-1, 1]), shape (count, n)."""
    acc = doc["accessors"][index]
    dtype, ncomp, count = COMPONENT[acc["componentType"]], NCOMP[acc["type"]], acc["count"]
    if "bufferView" in acc:
        a = _view_array(doc, buffers, acc["bufferView"], acc.get("byteOffset", 0), dtype, ncomp, count)
    else:
        a = np.zeros((count, ncomp), dtype=dtype)
    sparse = acc.get("sparse")
    if sparse:
        idx = sparse["indices"]
        ii = _view_array(doc, buffers, idx["bufferView"], idx.get("byteOffset", 0),
                         COMPONENT[idx["componentType"]], 1, sparse["count"]).reshape(-1)
        vals = sparse["values"]
        a[ii] = _view_array(doc, buffers, vals["bufferView"], vals.get("byteOffset", 0), dtype, ncomp,
                            sparse["count"])
    out = a.astype(np.float64)
    if acc.get("normalized"):
        info = np.iinfo(np.dtype(dtype))
        out = out / info.max
        if info.min < 0:
            out = np.maximum(out, -1.0)
    return out


def quat_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def node_matrix(node):
    if "matrix" in node:
        return np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T  # column-major
    m = np.eye(4)
    m[:3, :3] = quat_matrix(node.get("rotation", [0, 0, 0, 1])) @ np.diag(node.get("scale", [1, 1, 1]))
    m[:3, 3] = node.get("translation", [0, 0, 0])
    return m


def scene_mesh_nodes(doc):
    """(node index, node-to-world matrix) of every mesh node of the default scene."""
    scenes = doc.get("scenes", [])
    if scenes:
        roots = scenes[doc.get("scene", 0)].get("nodes", [])
    else:  # no scene: every root node
        children = {c for n in doc.get("nodes", []) for c in n.get("children", [])}
        roots = [i for i in range(len(doc.get("nodes", []))) if i not in children]
    stack = [(r, np.eye(4)) for r in roots]
    while stack:
        ni, parent = stack.pop()
        node = doc["nodes"][ni]
        world = parent @ node_matrix(node)
        stack.extend((c, world) for c in node.get("children", []))
        if "mesh" in node:
            yield ni, world


def baked_vertices(doc, buffers, node_index, world):
    """A baked node's vertices, in Blender world axes: dict of positions (N,3), normals (N,3) (zero
    where the file has none), radiance (N,3) from _RADIANCE, uv1 (N,2) from the lightmap's
    TEXCOORD_n (None without a lightmap) and triangles (M,3) into those rows."""
    mesh = doc["meshes"][doc["nodes"][node_index]["mesh"]]
    m = GLTF_TO_BLENDER @ world
    normal_m = np.linalg.inv(m[:3, :3]).T
    out = {"positions": [], "normals": [], "radiance": [], "uv1": [], "triangles": []}
    base = 0
    for prim in mesh["primitives"]:
        attrs = prim.get("attributes", {})
        if "_RADIANCE" not in attrs or "POSITION" not in attrs:
            continue
        p = read_accessor(doc, buffers, attrs["POSITION"])[:, :3]
        out["positions"].append((np.c_[p, np.ones(len(p))] @ m.T)[:, :3])
        if "NORMAL" in attrs:
            n = read_accessor(doc, buffers, attrs["NORMAL"])[:, :3] @ normal_m.T
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-30)
        else:
            n = np.zeros((len(p), 3))
        out["normals"].append(n)
        out["radiance"].append(read_accessor(doc, buffers, attrs["_RADIANCE"])[:, :3])
        material = doc["materials"][prim["material"]] if "material" in prim else {}
        lightmap = material.get("extensions", {}).get("MOZ_lightmap")
        if lightmap is not None:
            out["uv1"].append(read_accessor(doc, buffers, attrs["TEXCOORD_%d" % lightmap.get("texCoord", 0)]))
        idx = (read_accessor(doc, buffers, prim["indices"]).reshape(-1).astype(np.int64)
               if "indices" in prim else np.arange(len(p)))
        out["triangles"].append(idx.reshape(-1, 3) + base)
        base += len(p)
    if not out["positions"]:
        return None
    with_uv = len(out["uv1"]) == len(out["radiance"])  # every primitive reads the lightmap
    out["uv1"] = np.concatenate(out["uv1"]) if with_uv else None
    for key in ("positions", "normals", "radiance", "triangles"):
        out[key] = np.concatenate(out[key])
    return out
