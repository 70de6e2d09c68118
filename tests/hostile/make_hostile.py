#!/usr/bin/env python3
"""Generate radbake's hostile-input catalogue.

    python3 tests/hostile/make_hostile.py OUTDIR

Writes every case into OUTDIR/<case>/ and the list of cases with their expectations into
OUTDIR/cases.json (format: see README.md beside this file). Standard library only, deterministic,
a few seconds and a few MB. Things that do not survive being generated in advance (FIFOs,
symlinks, folders in the output) are not made here: the case asks the harness for them in
"setup".

The expectations follow radbake's error contract (README.md), not today's behaviour.
"""
import base64
import json
import os
import shutil
import struct
import sys
import zlib

ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
FLOAT, USHORT, UINT = 5126, 5123, 5125

# ----------------------------------------------------------------------------- the base scene
# A 2x2 floor (y = 0, facing up, grey) under a 0.5x0.5 emitter (y = 1, facing down).
# Layout (the cases rely on it):
#   accessor 0 floor POSITION (buffer view 0), 1 floor NORMAL (1), 2 floor indices (2),
#   accessor 3 light POSITION (3), 4 light NORMAL (4), 5 light indices (5),
#   [accessor 6 floor TEXCOORD_0 (6) when uv=True]
#   mesh 0 floor, mesh 1 light (or with one_mesh: mesh 0 with primitive 0 floor, 1 light),
#   node 0 floor, node 1 light, scene 0 = [0, 1];
#   material 0 floor, material 1 light (light_first: material 0 light, material 1 floor).
FLOOR = [(-1.0, 0.0, -1.0), (-1.0, 0.0, 1.0), (1.0, 0.0, 1.0), (1.0, 0.0, -1.0)]  # CCW seen from +y
LIGHT = [(-0.25, 1.0, -0.25), (0.25, 1.0, -0.25), (0.25, 1.0, 0.25), (-0.25, 1.0, 0.25)]  # CCW seen from -y
QUAD = [0, 1, 2, 0, 2, 3]
FLOOR_UV = [(0.0, 0.0), (0.0, 1.0), (1.0, 1.0), (1.0, 0.0)]


class Gltf:
    """A glTF document under construction: the JSON dict and one binary buffer."""

    def __init__(self):
        self.bin = bytearray()
        self.g = {"asset": {"version": "2.0", "generator": "radbake tests/hostile/make_hostile.py"},
                  "scene": 0, "scenes": [{"nodes": []}], "nodes": [], "meshes": [], "materials": [],
                  "accessors": [], "bufferViews": [], "buffers": []}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.g["bufferViews"].append(v)
        return len(self.g["bufferViews"]) - 1

    def accessor(self, values, ncomp, ctype=FLOAT, target=ARRAY_BUFFER, minmax=False):
        flat = [c for v in values for c in v] if ncomp > 1 else list(values)
        fmt = {FLOAT: "f", USHORT: "H", UINT: "I"}[ctype]
        view = self.view(struct.pack("<%d%s" % (len(flat), fmt), *flat), target)
        a = {"bufferView": view, "componentType": ctype, "count": len(flat) // ncomp,
             "type": {1: "SCALAR", 2: "VEC2", 3: "VEC3"}[ncomp]}
        if minmax:
            cols = [flat[i::ncomp] for i in range(ncomp)]
            a["min"] = [min(c) for c in cols]
            a["max"] = [max(c) for c in cols]
        self.g["accessors"].append(a)
        return len(self.g["accessors"]) - 1

    def quad_prim(self, pos, normal, material, uv=None):
        p = {"attributes": {"POSITION": self.accessor(pos, 3, minmax=True),
                            "NORMAL": self.accessor([normal] * 4, 3)},
             "indices": self.accessor(QUAD, 1, USHORT, ELEMENT_ARRAY_BUFFER), "material": material}
        if uv is not None:
            p["attributes"]["TEXCOORD_0"] = self.accessor(uv, 2)
        return p

    def use_extension(self, name):
        used = self.g.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)


def grey(rho=0.5):
    return {"pbrMetallicRoughness": {"baseColorFactor": [rho, rho, rho, 1.0], "metallicFactor": 0.0,
                                     "roughnessFactor": 1.0}}


def emitter(radiance=1.0):
    m = grey(0.0)
    m["emissiveFactor"] = [radiance, radiance, radiance]
    return m


def lit_scene(uv=False, one_mesh=False, light_first=False):
    """The minimal valid lit scene (layout above)."""
    d = Gltf()
    floor_mat, light_mat = (1, 0) if light_first else (0, 1)
    floor = d.quad_prim(FLOOR, (0.0, 1.0, 0.0), floor_mat)
    light = d.quad_prim(LIGHT, (0.0, -1.0, 0.0), light_mat)
    if uv:
        floor["attributes"]["TEXCOORD_0"] = d.accessor(FLOOR_UV, 2)
    mats = [grey(), emitter()]
    d.g["materials"] = mats[::-1] if light_first else mats
    if one_mesh:
        d.g["meshes"] = [{"name": "floor and light", "primitives": [floor, light]}]
        d.g["nodes"] = [{"name": "scene", "mesh": 0}]
        d.g["scenes"][0]["nodes"] = [0]
    else:
        d.g["meshes"] = [{"name": "floor", "primitives": [floor]}, {"name": "light", "primitives": [light]}]
        d.g["nodes"] = [{"name": "floor", "mesh": 0}, {"name": "light", "mesh": 1}]
        d.g["scenes"][0]["nodes"] = [0, 1]
    return d


def closed_box(rho=1.0, emissive_wall=0, size=1.0):
    """A closed cube seen from inside: six inward-facing quads, one material each (material i = wall i),
    wall `emissive_wall` also emits 1."""
    d = Gltf()
    s = size
    # (corner, edge u, edge v) with u x v pointing inward
    walls = [((0, 0, 0), (0, 0, s), (s, 0, 0)),    # floor y=0, normal +y
             ((0, s, 0), (s, 0, 0), (0, 0, s)),    # ceiling y=s, normal -y
             ((0, 0, 0), (s, 0, 0), (0, s, 0)),    # back z=0, normal +z
             ((0, 0, s), (0, s, 0), (s, 0, 0)),    # front z=s, normal -z
             ((0, 0, 0), (0, s, 0), (0, 0, s)),    # left x=0, normal +x
             ((s, 0, 0), (0, 0, s), (0, s, 0))]    # right x=s, normal -x
    prims = []
    for i, (o, u, v) in enumerate(walls):
        pos = [tuple(o[k] for k in range(3)), tuple(o[k] + u[k] for k in range(3)),
               tuple(o[k] + u[k] + v[k] for k in range(3)), tuple(o[k] + v[k] for k in range(3))]
        n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
        n = tuple(float(c / (s * s)) for c in n)
        pos = [tuple(float(c) for c in p) for p in pos]
        prims.append(d.quad_prim(pos, n, i))
        m = grey(rho)
        if i == emissive_wall:
            m["emissiveFactor"] = [1.0, 1.0, 1.0]
        d.g["materials"].append(m)
    d.g["meshes"] = [{"name": "box", "primitives": prims}]
    d.g["nodes"] = [{"name": "box", "mesh": 0}]
    d.g["scenes"][0]["nodes"] = [0]
    return d


# ----------------------------------------------------------------------------- writers
def data_uri(data):
    return "data:application/octet-stream;base64," + base64.b64encode(bytes(data)).decode()


def json_text(g):
    return json.dumps(g, indent=1, allow_nan=False)


def write(path, data):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(data.encode() if isinstance(data, str) else bytes(data))


def write_gltf(folder, d, name="scene.gltf", mode="datauri", bin_name="scene.bin", bin_uri=None,
               write_bin=True, text=None):
    """mode: datauri (buffer 0 embedded), external (buffer 0 in bin_name beside it), glb.
    bin_uri overrides the buffer's URI; write_bin=False leaves the .bin for someone else to make;
    text replaces the JSON text (for hand-made JSON)."""
    g = d.g
    if not g["buffers"]:
        g["buffers"] = [{"byteLength": len(d.bin)}]
    b = g["buffers"][0]
    if mode == "datauri":
        b.setdefault("uri", data_uri(d.bin))
    elif mode == "external":
        b.setdefault("uri", bin_uri or bin_name)
        if write_bin:
            write(os.path.join(folder, bin_name), d.bin)
    if mode == "glb":
        write(os.path.join(folder, name), glb(text if text is not None else json.dumps(g, allow_nan=False), d.bin))
    else:
        write(os.path.join(folder, name), text if text is not None else json_text(g))


def glb(json_str, bin_data=None, length=None):
    js = json_str.encode()
    while len(js) % 4:
        js += b" "
    chunks = struct.pack("<II", len(js), 0x4E4F534A) + js
    if bin_data is not None:
        bd = bytes(bin_data)
        while len(bd) % 4:
            bd += b"\0"
        chunks += struct.pack("<II", len(bd), 0x004E4942) + bd
    total = 12 + len(chunks)
    return struct.pack("<III", 0x46546C67, 2, total if length is None else length) + chunks


def png(width, height, idat, color_type=6):
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)) +
            chunk(b"IDAT", idat) + chunk(b"IEND", b""))


def small_png():
    """A valid 2x2 RGBA PNG."""
    raw = b"".join(b"\0" + b"\x80\x80\x80\xff" * 2 for _ in range(2))
    return png(2, 2, zlib.compress(raw))


def bomb_png(target=400_000, size=20000):
    """Header and IHDR of a 20000x20000 RGBA image, then ~target bytes of the (truncated) deflate
    stream of its all-zero rows, then IEND: 0.4 MB that claims 1.6 GB of pixels."""
    c = zlib.compressobj(9)
    zeros = bytes(1 << 22)
    out = bytearray()
    while len(out) < target:
        out += c.compress(zeros)
    out += c.flush(zlib.Z_SYNC_FLUSH)  # whole deflate blocks, but no final block: truncated
    return png(size, size, bytes(out[:target + 4096]))


def add_texture(d, material=0, uri="tex.png", buffer_view=None):
    img = {"uri": uri} if buffer_view is None else {"bufferView": buffer_view, "mimeType": "image/png"}
    d.g["images"] = [img]
    d.g["textures"] = [{"source": 0}]
    d.g["materials"][material]["pbrMetallicRoughness"]["baseColorTexture"] = {"index": 0}


def nested(kind, depth, leaf="0"):
    if kind == "array":
        return "[" * depth + leaf + "]" * depth
    return '{"a":' * depth + leaf + "}" * depth


def deep_extras_text(d, kind, depth):
    """JSON text of d with asset.extras replaced by `depth` nested arrays or objects (json.dumps
    itself would recurse that deep)."""
    d.g["asset"]["extras"] = "@@DEEP@@"
    if not d.g["buffers"]:
        d.g["buffers"] = [{"byteLength": len(d.bin), "uri": data_uri(d.bin)}]
    return json.dumps(d.g).replace('"@@DEEP@@"', nested(kind, depth))


# ----------------------------------------------------------------------------- the catalogue
CASES = []


def case(name, bullet, args, expect_exit, expect=None, outputs=None, cwd=None, setup=None, **extra):
    assert not any(c["name"] == name for c in CASES), name
    c = {"name": name, "bullet": bullet, "args": args, "expect_exit": expect_exit, "expect": expect,
         "outputs": outputs if outputs is not None else (["o.glb"] if expect_exit == 0 else [])}
    if cwd:
        c["cwd"] = cwd
    if setup:
        c["setup"] = setup
    c.update(extra)
    CASES.append(c)


def bake(inp="scene.gltf", *more, out="o.glb"):
    return ["bake", "{case}/" + inp if not inp.startswith("/") else inp, "-o", "{out}/" + out] + list(more)


ELEM = lambda e, *words: "(?i)%s\\b.*(%s)|(%s).*%s\\b" % (e, "|".join(words), "|".join(words), e) if words else "(?i)%s\\b" % e


def build(root):
    def folder(name):
        return os.path.join(root, name)

    # ---- sanity: the base scene itself, in all three containers
    for mode in ("datauri", "external", "glb"):
        n = "ok_base_" + mode
        write_gltf(folder(n), lit_scene(), name="scene.glb" if mode == "glb" else "scene.gltf", mode=mode)
        case(n, "sanity: the base scene bakes", bake("scene.glb" if mode == "glb" else "scene.gltf"), 0)

    write_gltf(folder("ok_new_options"), lit_scene())
    case("ok_new_options", "sanity: --max-memory 2G --strict --allow-outside-paths on the base scene",
         bake("scene.gltf", "--max-memory", "2G", "--strict", "--allow-outside-paths"), 0)
    write_gltf(folder("ok_probe"), lit_scene())
    write(os.path.join(folder("ok_probe"), "probe.csv"), "x,y,z,nx,ny,nz\n0,0,0,0,1,0\n")
    case("ok_probe", "sanity: --probe on the base scene", bake("scene.gltf", "--probe", "{case}/probe.csv",
         "--probe-out", "{out}/p.csv"), 0, outputs=["o.glb", "p.csv"],
         output_match={"p.csv": "x,y,z,r,g,b\n[-+0-9.eE]+(,[-+0-9.eE]+){5}\n"})

    # ---- A. crashes
    d = lit_scene(one_mesh=True)
    depth = 30000
    d.g["nodes"] = [{"children": [i + 1]} for i in range(depth - 1)] + [{"name": "leaf", "mesh": 0}]
    d.g["scenes"][0]["nodes"] = [0]
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": data_uri(d.bin)}]
    write(os.path.join(folder("a_node_chain_30000"), "scene.gltf"), json.dumps(d.g, separators=(",", ":")))
    case("a_node_chain_30000", "A: node chain 30,000 deep (valid)", bake(), 0)

    for kind in ("array", "object"):
        n = "a_extras_%ss_20000" % kind
        write(os.path.join(folder(n), "scene.gltf"), deep_extras_text(lit_scene(), kind, 20000))
        case(n, "A: JSON %ss nested 20,000 deep in extras" % kind, bake(), 2, "(?i)nest|deep|depth")
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin)}]
    text = deep_extras_text(d, "array", 20000)
    write(os.path.join(folder("a_glb_deep_nesting"), "scene.glb"), glb(text, d.bin))
    case("a_glb_deep_nesting", "A: 20,000-deep arrays in a .glb JSON chunk", bake("scene.glb"), 2,
         "(?i)nest|deep|depth")

    # ---- B. memory and time
    d = Gltf()
    tri = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, -1.0)]
    d.accessor(tri, 3, minmax=True)  # 36 bytes
    d.g["accessors"][0]["count"] = 1_000_000_000
    d.g["materials"] = [emitter()]
    d.g["meshes"] = [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}]
    d.g["nodes"] = [{"mesh": 0}]
    d.g["scenes"][0]["nodes"] = [0]
    write_gltf(folder("b_accessor_count_1e9"), d)
    case("b_accessor_count_1e9", "B: accessor count 1e9 over a 36-byte buffer", bake(), 2, ELEM("accessor 0"))

    d = lit_scene()
    d.g["accessors"][0].update(count=2 ** 61, byteOffset=9007199254740000)
    write_gltf(folder("b_accessor_offset_overflow"), d)
    case("b_accessor_offset_overflow", "B: accessor byteOffset + count overflow 64 bits", bake(), 2,
         ELEM("accessor 0"))

    d = lit_scene()
    d.g["bufferViews"][0]["byteLength"] = len(d.bin) + 64
    write_gltf(folder("b_buffer_view_past_buffer"), d)
    case("b_buffer_view_past_buffer", "B: buffer view longer than its buffer", bake(), 2, ELEM("buffer view 0"))

    d = lit_scene()
    d.g["buffers"] = [{"byteLength": 10 ** 15, "uri": data_uri(d.bin)}]
    write_gltf(folder("b_buffer_bytelength_1e15"), d)
    case("b_buffer_bytelength_1e15", "B: buffer byteLength 1e15, tiny data URI", bake(), 2, ELEM("buffer 0"))

    d = lit_scene(uv=True)
    add_texture(d, 0, "bomb.png")
    write_gltf(folder("b_png_bomb"), d)
    write(os.path.join(folder("b_png_bomb"), "bomb.png"), bomb_png())
    case("b_png_bomb", "B: 0.4 MB truncated PNG claiming 20000x20000 RGBA", bake(), 0, "(?i)image 0|texture 0")

    d = lit_scene(uv=True)
    d.g["buffers"] = [{"byteLength": 0}]
    raw = bomb_png(100_000, 8192)
    d.bin += b"\0" * ((-len(d.bin)) % 4)
    view = d.view(raw)
    add_texture(d, 0, buffer_view=view)
    d.g["buffers"] = [{"byteLength": len(d.bin)}]
    write(os.path.join(folder("b_png_bomb_8k_in_glb"), "scene.glb"), glb(json.dumps(d.g), d.bin))
    case("b_png_bomb_8k_in_glb", "B: truncated 8192x8192 RGBA PNG inside a .glb", bake("scene.glb"), 0,
         "(?i)image 0|texture 0")

    # 20,000 triangles (a 100x100 grid of quads) instanced by 50,000 nodes, plus the light
    d = lit_scene()
    g = 100
    pos = [(x / g, 0.0, -z / g) for z in range(g + 1) for x in range(g + 1)]
    idx = []
    for z in range(g):
        for x in range(g):
            a, b = z * (g + 1) + x, z * (g + 1) + x + 1
            c, e = b + g + 1, a + g + 1
            idx += [a, b, c, a, c, e]
    p = {"attributes": {"POSITION": d.accessor(pos, 3, minmax=True)},
         "indices": d.accessor(idx, 1, USHORT, ELEMENT_ARRAY_BUFFER), "material": 0}
    d.g["meshes"].append({"name": "grid 20000 triangles", "primitives": [p]})
    d.g["nodes"] += [{"mesh": 2, "translation": [float(i % 250) * 1.1, -0.5 - float(i // 250) * 0.01, 0.0]}
                     for i in range(50000)]
    d.g["scenes"][0]["nodes"] += list(range(2, 50002))
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": "scene.bin"}]
    write(os.path.join(folder("b_instanced_1e9_triangles"), "scene.bin"), d.bin)
    write(os.path.join(folder("b_instanced_1e9_triangles"), "scene.gltf"), json.dumps(d.g, separators=(",", ":")))
    case("b_instanced_1e9_triangles", "B: 20,000 triangles instanced by 50,000 nodes", bake(), 3,
         "(?i)triangle|budget|memory")

    os.makedirs(folder("b_dev_zero_input"), exist_ok=True)
    case("b_dev_zero_input", "B: /dev/zero as the input", bake("/dev/zero"), 2, "(?i)regular")

    os.makedirs(folder("b_fifo_input"), exist_ok=True)
    case("b_fifo_input", "B: a FIFO as the input", bake("in.gltf"), 2, "(?i)regular",
         setup=[{"mkfifo": "in.gltf"}])

    write_gltf(folder("b_fifo_buffer"), lit_scene(), mode="external", write_bin=False)
    case("b_fifo_buffer", "B: a FIFO as a buffer URI", bake(), 2, ELEM("buffer 0"), setup=[{"mkfifo": "scene.bin"}])

    d = lit_scene(uv=True)
    add_texture(d, 0, "tex.png")
    write_gltf(folder("b_fifo_image"), d)
    case("b_fifo_image", "B: a FIFO as an image URI", bake(), 2, ELEM("image 0"), setup=[{"mkfifo": "tex.png"}])
    write_gltf(folder("b_fifo_ocio_config"), lit_scene())
    case("b_fifo_ocio_config", "B: a FIFO as --ocio-config", bake("scene.gltf", "--ocio-config", "{case}/config.ocio"), 2,
         "(?i)config\\.ocio.*regular", setup=[{"mkfifo": "config.ocio"}])

    pts = ["%g %g %g" % (i / 3.0, j / 3.0, 0.3 * ((i - 1.5) ** 2 - (j - 1.5) ** 2)) for i in range(4) for j in range(4)]
    write(os.path.join(folder("b_bpt_max_chord_1e-12"), "patch.bpt"), "1\n3 3\n" + "\n".join(pts) + "\n")
    # A chord no tessellation can meet is a usage error (exit 1), said at once instead of a bake
    # that runs for hours.
    case("b_bpt_max_chord_1e-12", "B: one bicubic patch with --max-chord 1e-12",
         bake("patch.bpt", "--max-chord", "1e-12"), 1, "(?i)--max-chord 1e-12 cannot be met")

    write_gltf(folder("b_cube_subdivide_4096"), closed_box(rho=0.5))
    case("b_cube_subdivide_4096", "B: a cube with --subdivide 4096", bake("scene.gltf", "--subdivide", "4096"), 3,
         "(?i)subdivide|patch|budget|memory")

    write_gltf(folder("b_max_edge_1e-9"), lit_scene())
    case("b_max_edge_1e-9", "B: --max-edge 1e-9", bake("scene.gltf", "--max-edge", "1e-9"), 3,
         "(?i)max-edge|patch|budget|memory")

    # Below 64M no bake can run: a usage error.
    write_gltf(folder("b_max_memory_1M"), lit_scene())
    case("b_max_memory_1M", "B: --max-memory 1M on the base scene", bake("scene.gltf", "--max-memory", "1M"), 1,
         "(?i)--max-memory")

    # The floor placed by 100,000 nodes: 200,000 triangles, about 200 MiB estimated, past 64M.
    d = lit_scene()
    d.g["nodes"] += [{"mesh": 0, "translation": [0.0, -0.001 * (i + 1), 0.0]} for i in range(100000)]
    d.g["scenes"][0]["nodes"] += list(range(2, 100002))
    write_gltf(folder("b_max_memory_64M_instances"), d)
    case("b_max_memory_64M_instances", "B: --max-memory 64M on 100,000 instances of the floor",
         bake("scene.gltf", "--max-memory", "64M"), 3, "(?i)node \\d+: .*triangles.*--max-memory")

    # ---- C. reading outside the asset's folder: case/asset/scene.gltf, the secret in case/outside.bin
    def outside_case(n, uri, more=(), expect_exit=2, expect=None, setup=None, cwd=None, secret=True, **kw):
        d = lit_scene()
        d.g["buffers"] = [{"byteLength": len(d.bin), "uri": uri}]
        f = folder(n)
        write(os.path.join(f, "asset", "scene.gltf"), json_text(d.g))
        if secret:
            write(os.path.join(f, "outside.bin"), d.bin)  # exactly right: only the path rule can refuse it
        case(n, kw.pop("bullet"), bake("asset/scene.gltf", *more), expect_exit,
             expect if expect is not None else ELEM("buffer 0"), setup=setup, cwd=cwd, **kw)
        return f

    outside_case("c_dotdot_buffer", "../outside.bin", bullet="C: buffer URI ../outside.bin")
    outside_case("c_dotdot_buffer_allowed", "../outside.bin", ["--allow-outside-paths"], 0, None,
                 bullet="C: ../outside.bin with --allow-outside-paths")
    outside_case("c_pct_dotdot_upper", "%2E%2E/outside.bin", bullet="C: %2E%2E/outside.bin")
    outside_case("c_pct_dotdot_slash_lower", "%2e%2e%2Foutside.bin", bullet="C: %2e%2e%2Foutside.bin")
    outside_case("c_symlink_buffer", "link.bin", setup=[{"symlink": ["asset/link.bin", "../outside.bin"]}],
                 bullet="C: asset/link.bin -> ../outside.bin")
    f = folder("c_absolute_buffer")
    outside_case("c_absolute_buffer", os.path.join(f, "outside.bin"), bullet="C: absolute buffer URI")
    f = folder("c_file_uri_buffer")
    outside_case("c_file_uri_buffer", "file://" + os.path.join(f, "outside.bin"), bullet="C: file:///abs URI")
    f = outside_case("c_cwd_fallback", "wd.bin", cwd="wd", secret=False,
                     bullet="C: wd.bin only in the working directory")
    write(os.path.join(f, "wd", "wd.bin"), lit_scene().bin)
    d = lit_scene(uv=True)
    add_texture(d, 0, "../outside.png")
    write_gltf(os.path.join(folder("c_dotdot_image"), "asset"), d)
    write(os.path.join(folder("c_dotdot_image"), "outside.png"), small_png())
    case("c_dotdot_image", "C: image URI ../outside.png", bake("asset/scene.gltf"), 2, ELEM("image 0"))
    f = outside_case("c_buffer_is_directory", "dir.bin", secret=False,
                     expect="(?i)^(?!.*out of memory)(.*buffer 0\\b)", bullet="C: buffer URI is a directory")
    os.makedirs(os.path.join(f, "asset", "dir.bin"), exist_ok=True)
    outside_case("c_dev_zero_buffer_allowed", "/dev/zero", ["--allow-outside-paths"], secret=False,
                 expect="(?i)^(?=.*buffer 0\\b).*regular", bullet="C: /dev/zero URI with --allow-outside-paths")

    # ---- D. no data lost on failure
    # A bake replaces the asset's materials: no output may be the input, however it is spelled.
    write_gltf(folder("d_output_is_input"), lit_scene(), name="scene.glb", mode="glb")
    case("d_output_is_input", "D: -o the input .glb",
         ["bake", "{case}/scene.glb", "-o", "{case}/scene.glb", "--report", "{out}/r.json"], 1,
         "(?i)-o .*scene\\.glb is the input")
    write_gltf(folder("d_output_is_input_spelled"), lit_scene(), name="scene.glb", mode="glb")
    case("d_output_is_input_spelled", "D: -o the input .glb through ./ and ..",
         ["bake", "{case}/scene.glb", "-o", "{case}/./../d_output_is_input_spelled/scene.glb"], 1,
         "(?i)-o .*scene\\.glb is the input")
    write_gltf(folder("d_probe_out_is_input"), lit_scene())
    write(os.path.join(folder("d_probe_out_is_input"), "probe.csv"), "x,y,z,nx,ny,nz\n0,0,0,0,1,0\n")
    case("d_probe_out_is_input", "D: --probe-out names the input",
         bake("scene.gltf", "--probe", "{case}/probe.csv", "--probe-out", "{case}/scene.gltf"), 1, "(?i)--probe-out.*input")
    write_gltf(folder("d_probe_out_is_output"), lit_scene())
    write(os.path.join(folder("d_probe_out_is_output"), "probe.csv"), "x,y,z,nx,ny,nz\n0,0,0,0,1,0\n")
    case("d_probe_out_is_output", "D: --probe-out names the -o file",
         bake("scene.gltf", "--probe", "{case}/probe.csv", "--probe-out", "{out}/o.glb"), 1, "(?i)--probe-out.*-o file")
    write_gltf(folder("d_report_missing_folder"), lit_scene())
    case("d_report_missing_folder", "D: --report into a missing folder",
         bake("scene.gltf", "--report", "{out}/missing/r.json"), 4, "(?i)missing|r\\.json|report|director")
    probe_csv = "x,y,z,nx,ny,nz\n0,0,0,0,1,0\n0.5,0,0.5,0,1,0\n"
    write_gltf(folder("d_probe_out_missing_folder"), lit_scene())
    write(os.path.join(folder("d_probe_out_missing_folder"), "probe.csv"), probe_csv)
    case("d_probe_out_missing_folder", "D: --probe-out into a missing folder",
         bake("scene.gltf", "--probe", "{case}/probe.csv", "--probe-out", "{out}/missing/p.csv"), 4,
         "(?i)missing|p\\.csv|probe|director")
    write_gltf(folder("d_probe_out_missing_lightmap"), lit_scene())
    write(os.path.join(folder("d_probe_out_missing_lightmap"), "probe.csv"), probe_csv)
    case("d_probe_out_missing_lightmap", "D: --probe-out missing folder with --lightmap",
         bake("scene.gltf", "--probe", "{case}/probe.csv", "--probe-out", "{out}/missing/p.csv",
              "--lightmap", "{out}/lm.exr"), 4, "(?i)missing|p\\.csv|probe|director")
    write_gltf(folder("d_lightmap_missing_folder"), lit_scene())
    case("d_lightmap_missing_folder", "D: --lightmap into a missing folder",
         bake("scene.gltf", "--lightmap", "{out}/missing/lm.exr"), 4, "(?i)missing|lm\\.exr|lightmap|director")

    # A warning is one bounded line too: a material named with 100,000 characters and a newline.
    d = lit_scene()
    d.g["materials"][0]["name"] = "m" * 50000 + "\n" + "x" * 50000
    d.g["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = [1.5, 1.5, 1.5, 1.0]
    write_gltf(folder("e_long_material_name_warning"), d)
    case("e_long_material_name_warning", "E: a clamped base color on a material with a 100,000-character name",
         bake(), 0, "(?i)material 0")

    # ---- E. wrong numbers
    for n, factor in (("e_basecolor_1.5", [1.5, 1.5, 1.5, 1.0]), ("e_basecolor_1e300", [1e300, 1e300, 1e300, 1.0]),
                      ("e_basecolor_negative", [-0.5, -0.5, -0.5, 1.0])):
        d = lit_scene()
        d.g["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = factor
        write_gltf(folder(n), d)
        case(n, "E: baseColorFactor %s" % factor[0], bake(), 0, ELEM("material 0"))
    for n, strength, code in (("e_emissive_strength_1e308", 1e308, 2), ("e_emissive_strength_negative", -2.0, 0)):
        d = lit_scene(light_first=True)
        d.g["materials"][0]["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
        d.use_extension("KHR_materials_emissive_strength")
        write_gltf(folder(n), d)
        case(n, "E: emissive strength %g" % strength, bake(), code, ELEM("material 0"))
    d = lit_scene()
    d.g["extensions"] = {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1e300}]}}
    d.use_extension("KHR_lights_punctual")
    d.g["nodes"].append({"name": "lamp", "translation": [0.0, 0.5, 0.0],
                         "extensions": {"KHR_lights_punctual": {"light": 0}}})
    d.g["scenes"][0]["nodes"].append(2)
    write_gltf(folder("e_point_light_1e300"), d)
    case("e_point_light_1e300", "E: point light intensity 1e300", bake(), 2, ELEM("light 0"))
    write_gltf(folder("e_closed_box_rho1"), closed_box(rho=1.0))
    case("e_closed_box_rho1", "E: closed box, all reflectances 1: no convergence", bake(), 0, "(?i)converg")
    write_gltf(folder("e_closed_box_rho1_strict"), closed_box(rho=1.0))
    case("e_closed_box_rho1_strict", "E: the same with --strict", bake("scene.gltf", "--strict"), 5,
         "(?i)converg")
    for opt, val, more in (("--tolerance", "nan", []), ("--max-edge", "nan", []), ("--max-chord", "nan", []),
                           ("--exposure", "inf", []), ("--exposure", "nan", []), ("--exposure", "1e308", []),
                           ("--exposure", "-1e308", []), ("--texel-size", "nan", ["--lightmap", "{out}/lm.exr"]),
                           ("--sky", "nan", []), ("--sky", "1,nan,1", []), ("--sky", "inf", []),
                           ("--max-memory", "-5", []), ("--max-memory", "banana", [])):
        n = "e_option_%s_%s" % (opt.strip("-").replace("-", "_"), val.replace(",", "_"))
        write_gltf(folder(n), lit_scene())
        case(n, "E: option %s %s" % (opt, val), bake("scene.gltf", opt, val, *more), 1, "(?i)" + opt)

    # ---- F. invalid files
    d = lit_scene()
    d.g["bufferViews"][0]["byteStride"] = 4
    write_gltf(folder("f_stride_4_vec3"), d)
    case("f_stride_4_vec3", "F: byteStride 4 on a VEC3 FLOAT accessor", bake(), 2, "(?i)stride")
    d = lit_scene()
    d.g["meshes"][0]["primitives"][0]["mode"] = 7
    write_gltf(folder("f_mode_7"), d)
    case("f_mode_7", "F: primitive mode 7", bake(), 2, ELEM("mesh 0 primitive 0"))
    d = lit_scene()
    d.g["scenes"][0]["nodes"] = [0, 1, 0]
    write_gltf(folder("f_scene_root_twice"), d)
    case("f_scene_root_twice", "F: a scene lists node 0 twice", bake(), 2, ELEM("scene 0"))
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": data_uri(d.bin) + "!!garbage!!"}]
    write_gltf(folder("f_base64_trailing_garbage"), d)
    case("f_base64_trailing_garbage", "F: garbage after the base64 of a data URI", bake(), 2, ELEM("buffer 0"))
    d = lit_scene()
    d.g["meshes"][0]["primitives"] = []
    write_gltf(folder("f_mesh_no_primitives"), d)
    case("f_mesh_no_primitives", "F: a mesh with zero primitives", bake(), 2, ELEM("mesh 0"))

    # ---- G. messages
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin)}]
    write(os.path.join(folder("g_glb_no_bin_chunk"), "scene.glb"), glb(json.dumps(d.g)))
    case("g_glb_no_bin_chunk", "G: .glb buffer 0 without uri, no BIN chunk", bake("scene.glb"), 2, ELEM("buffer 0"))
    d = lit_scene()
    raw = b"".join(struct.pack("<3f", *p) + b"\0" for p in FLOOR)[:13 * 3 + 12]  # positions at a 13-byte stride
    d.bin += b"\0" * ((-len(d.bin)) % 4)
    d.g["bufferViews"][0] = {"buffer": 0, "byteOffset": len(d.bin), "byteLength": len(raw), "byteStride": 13,
                             "target": ARRAY_BUFFER}
    d.bin += raw
    write_gltf(folder("g_stride_13"), d)
    case("g_stride_13", "G: byteStride 13 (floats unaligned)", bake(), 2, "(?i)buffer view 0\\b|accessor 0\\b|stride")
    d = lit_scene()
    d.g["accessors"][0]["componentType"] = 5000
    write_gltf(folder("g_component_type_5000"), d)
    case("g_component_type_5000", "G: componentType 5000", bake(), 2, ELEM("accessor 0"))
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": ""}]
    write_gltf(folder("g_empty_uri"), d)
    case("g_empty_uri", "G: buffer URI \"\"", bake(), 2, ELEM("buffer 0"))
    d = lit_scene()
    n_b64 = 3 * 1024 * 1024
    d.g["buffers"] = [{"byteLength": n_b64 // 4 * 3, "uri": "data:application/octet-stream;base64," + "*" * n_b64}]
    write_gltf(folder("g_3mb_invalid_base64"), d)
    case("g_3mb_invalid_base64", "G: 3 MB data URI of invalid base64", bake(), 2, ELEM("buffer 0"))
    write_gltf(folder("g_empty_probe_file"), lit_scene())
    write(os.path.join(folder("g_empty_probe_file"), "empty.csv"), b"")
    case("g_empty_probe_file", "G: an empty probe file",
         bake("scene.gltf", "--probe", "{case}/empty.csv", "--probe-out", "{out}/p.csv"), 0, None,
         outputs=["o.glb", "p.csv"], output_match={"p.csv": "[^\\n]*\\n?"})

    # ---- X. more that an attacker or a careless user would try
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin)}]
    good = glb(json.dumps(d.g), d.bin)
    write(os.path.join(folder("x_glb_length_too_long"), "scene.glb"), good[:8] + struct.pack("<I", len(good) + 1000) + good[12:])
    case("x_glb_length_too_long", "X: GLB length field larger than the file", bake("scene.glb"), 2,
         "(?i)scene\\.glb.*(length|truncat|bytes)")
    write(os.path.join(folder("x_glb_length_4g"), "scene.glb"), good[:8] + struct.pack("<I", 0xFFFFFFFF) + good[12:])
    case("x_glb_length_4g", "X: GLB length field 0xFFFFFFFF", bake("scene.glb"), 2, "(?i)scene\\.glb.*(length|truncat|bytes)")
    js = json.dumps(d.g).encode()
    js += b" " * ((-len(js)) % 4)
    lie = bytearray(good)
    struct.pack_into("<I", lie, 12, 0xFFFFFFF0)  # JSON chunk length
    write(os.path.join(folder("x_glb_chunk_length_lies"), "scene.glb"), lie)
    case("x_glb_chunk_length_lies", "X: GLB JSON chunk length 0xFFFFFFF0", bake("scene.glb"), 2,
         "(?i)scene\\.glb.*(length|truncat|chunk|bytes)")
    write(os.path.join(folder("x_glb_truncated_header"), "scene.glb"), good[:16])
    case("x_glb_truncated_header", "X: GLB of 16 bytes", bake("scene.glb"), 2, "(?i)scene\\.glb")
    for n, text in (("x_json_array", "[1, 2, 3]"), ("x_json_null", "null"), ("x_json_string", '"glTF"'),
                    ("x_json_truncated", json_text(lit_scene().g)[:200]), ("x_json_nan_token", None)):
        if text is None:
            d = lit_scene()
            d.g["nodes"][0]["matrix"] = "@@M@@"
            d.g["buffers"] = [{"byteLength": len(d.bin), "uri": data_uri(d.bin)}]
            text = json.dumps(d.g).replace('"@@M@@"', "[NaN,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]")
        write(os.path.join(folder(n), "scene.gltf"), text)
        case(n, "X: JSON that is not a glTF object (%s)" % n[7:], bake(), 2, "(?i)scene\\.gltf")
    write(os.path.join(folder("x_zero_byte_gltf"), "scene.gltf"), b"")
    case("x_zero_byte_gltf", "X: a 0-byte .gltf", bake(), 2, "(?i)scene\\.gltf")
    write(os.path.join(folder("x_zero_byte_glb"), "scene.glb"), b"")
    case("x_zero_byte_glb", "X: a 0-byte .glb", bake("scene.glb"), 2, "(?i)scene\\.glb")
    write(os.path.join(folder("x_zero_byte_bpt"), "scene.bpt"), b"")
    case("x_zero_byte_bpt", "X: a 0-byte .bpt", bake("scene.bpt"), 2, "(?i)scene\\.bpt")
    os.makedirs(os.path.join(folder("x_input_is_directory"), "dir.gltf"), exist_ok=True)
    case("x_input_is_directory", "X: the input is a directory", bake("dir.gltf"), 2, "(?i)dir\\.gltf.*(regular|directory)")
    os.makedirs(folder("x_input_missing"), exist_ok=True)
    case("x_input_missing", "X: the input does not exist", bake("nothing.gltf"), 2, "(?i)nothing\\.gltf")
    d = lit_scene()
    d.g["nodes"][0]["matrix"] = "@@M@@"
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": data_uri(d.bin)}]
    write(os.path.join(folder("x_matrix_1e400"), "scene.gltf"),
          json.dumps(d.g).replace('"@@M@@"', "[1e400,0,0,0, 0,1,0,0, 0,0,1,0, 0,0,0,1]"))
    case("x_matrix_1e400", "X: node matrix with 1e400 (infinite)", bake(), 2, "(?i)node 0\\b|range|finite|number|json")
    d = lit_scene()
    d.bin[d.g["bufferViews"][2]["byteOffset"] + 4:d.g["bufferViews"][2]["byteOffset"] + 6] = struct.pack("<H", 999)
    write_gltf(folder("x_index_past_position"), d)
    case("x_index_past_position", "X: an index past the end of POSITION", bake(), 2,
         "(?i)accessor 2\\b|mesh 0 primitive 0\\b")
    d = lit_scene()
    d.g["nodes"][0]["children"] = [1]
    d.g["nodes"][1]["children"] = [0]
    write_gltf(folder("x_node_cycle"), d)
    case("x_node_cycle", "X: nodes 0 and 1 each other's child", bake(), 2, "(?i)node [01]\\b|scene 0\\b")
    d = lit_scene()
    d.g["nodes"][0]["children"] = [0]
    write_gltf(folder("x_node_own_child"), d)
    case("x_node_own_child", "X: node 0 its own child", bake(), 2, ELEM("node 0"))
    d = lit_scene()
    d.g["nodes"].append({"children": [1]})
    d.g["nodes"][0]["children"] = [1]
    d.g["scenes"][0]["nodes"] = [0, 2]
    write_gltf(folder("x_node_two_parents"), d)
    case("x_node_two_parents", "X: node 1 child of nodes 0 and 2", bake(), 2, "(?i)node [012]\\b")
    d = lit_scene()
    d.g["accessors"][0]["count"] = -1
    write_gltf(folder("x_accessor_negative_count"), d)
    case("x_accessor_negative_count", "X: accessor count -1", bake(), 2, ELEM("accessor 0"))
    d = lit_scene()
    d.g["accessors"][0]["sparse"] = {"count": 1_000_000_000,
                                     "indices": {"bufferView": 2, "componentType": USHORT},
                                     "values": {"bufferView": 1}}
    write_gltf(folder("x_sparse_count_1e9"), d)
    case("x_sparse_count_1e9", "X: sparse accessor with 1e9 entries", bake(), 2, ELEM("accessor 0"))
    d = lit_scene()
    d.g["bufferViews"][0]["buffer"] = 5
    write_gltf(folder("x_buffer_index_out_of_range"), d)
    case("x_buffer_index_out_of_range", "X: buffer view 0 names buffer 5", bake(), 2, ELEM("buffer view 0"))
    d = lit_scene()
    d.g["nodes"][0]["mesh"] = 99
    write_gltf(folder("x_mesh_index_out_of_range"), d)
    case("x_mesh_index_out_of_range", "X: node 0 names mesh 99", bake(), 2, ELEM("node 0"))
    d = lit_scene()
    d.g["meshes"][0]["primitives"][0]["material"] = 99
    write_gltf(folder("x_material_index_out_of_range"), d)
    case("x_material_index_out_of_range", "X: primitive names material 99", bake(), 2, ELEM("mesh 0 primitive 0"))
    d = lit_scene()
    d.g["scene"] = 5
    write_gltf(folder("x_scene_index_out_of_range"), d)
    case("x_scene_index_out_of_range", "X: default scene 5 of 1", bake(), 2, "(?i)scene 5\\b|\\bscene\\b")
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": "a" * 100000 + ".bin"}]
    write_gltf(folder("x_long_uri"), d)
    case("x_long_uri", "X: a 100,000-character buffer URI", bake(), 2, ELEM("buffer 0"))
    d = lit_scene()
    d.g["buffers"] = [{"byteLength": len(d.bin), "uri": "evil\nerror: injected\r\x1b[31m.bin"}]
    write_gltf(folder("x_uri_control_chars"), d)
    case("x_uri_control_chars", "X: newline and ANSI escape in a URI", bake(), 2, ELEM("buffer 0"))
    write_gltf(folder("x_output_is_directory"), lit_scene())
    case("x_output_is_directory", "X: -o names an existing directory", bake("scene.gltf", out="sub.glb"), 4,
         "(?i)sub\\.glb", setup=[{"mkdir_out": "sub.glb"}], outputs=[])
    write_gltf(folder("x_output_bad_extension"), lit_scene())
    case("x_output_bad_extension", "X: -o o.txt", bake("scene.gltf", out="o.txt"), 1, "(?i)o\\.txt|output")
    write(os.path.join(folder("x_bpt_count_lies"), "scene.bpt"), "4194304\n3 3\n" + "\n".join(pts) + "\n")
    case("x_bpt_count_lies", "X: .bpt says 4M patches, has one", bake("scene.bpt"), 2, "(?i)scene\\.bpt.*patch 1\\b|end")
    write(os.path.join(folder("x_bpt_nan"), "scene.bpt"), "1\n3 3\nnan 0 0\n" + "\n".join(pts[1:]) + "\n")
    case("x_bpt_nan", "X: .bpt control point nan", bake("scene.bpt"), 2, "(?i)patch 0\\b")
    d = lit_scene(uv=True)
    add_texture(d, 0, "tex.png")
    write_gltf(folder("x_image_missing"), d)
    case("x_image_missing", "X: image file missing", bake(), 2, ELEM("image 0"))
    d = lit_scene(uv=True)
    add_texture(d, 0, "garbage.png")
    write_gltf(folder("x_image_garbage"), d)
    write(os.path.join(folder("x_image_garbage"), "garbage.png"), b"\x89PNG\r\n\x1a\n" + b"\xff" * 100)
    case("x_image_garbage", "X: undecodable image: a warning, the factor alone", bake(), 0, "(?i)image 0\\b|texture 0\\b")

def main():
    if len(sys.argv) != 2:
        sys.exit("usage: make_hostile.py OUTDIR")
    root = os.path.abspath(sys.argv[1])
    if os.path.isdir(root):
        # only ever clear a folder this script made (or an empty one)
        if os.listdir(root) and not os.path.exists(os.path.join(root, "cases.json")):
            sys.exit("make_hostile.py: %s is not empty and holds no cases.json; refusing to clear it" % root)
        shutil.rmtree(root)
    os.makedirs(root)
    build(root)
    for c in CASES:
        os.makedirs(os.path.join(root, c["name"]), exist_ok=True)
    with open(os.path.join(root, "cases.json"), "w") as f:
        json.dump(CASES, f, indent=1)
        f.write("\n")
    print("make_hostile.py: %d cases in %s" % (len(CASES), root))


if __name__ == "__main__":
    main()
