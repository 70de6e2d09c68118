"""Shared helpers for the Fig. 11 reproduction and the convergence study (bench/fig11).

Everything here is deterministic: probe grids are fixed, bakes are run one at a time with a fixed
thread count, and the tables are printed with fixed formats.
"""
import base64
import json
import math
import os
import platform
import subprocess
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.abspath(os.path.join(HERE, "..", ".."))
RADBAKE = os.environ.get("RADBAKE", os.path.join(ROOT, "build", "plugin", "cli", "radbake"))
# Scenes and reference values: tests/data, or another copy named by RADBAKE_TEST_DATA_DIR.
TEST_DATA = os.environ.get("RADBAKE_TEST_DATA_DIR", os.path.join(ROOT, "tests", "data"))
OUT = os.path.join(HERE, "out")
IMAGES = os.path.join(ROOT, "docs", "images")

# Solver tolerance for every bake here: far below the discretisation errors we measure.
TOLERANCE = "1e-11"


def log(*a):
    print(*a, flush=True)


# ---------------------------------------------------------------------------------------------
# Probe grids
# ---------------------------------------------------------------------------------------------

def cell_centres(m):
    """(2i+1)/(2m), i = 0..m-1. With m a multiple of 32 (2m a multiple of 64) no centre lies on a
    patch edge k/N for any N < 64 that is not a multiple of 64: (2i+1)N = 2mk would need the power of
    two in N to reach that of 2m."""
    return (2 * np.arange(m) + 1) / (2.0 * m)


# Unit cube seen from inside: face -> (point(u, v), inward normal).
CUBE_FACES = {
    "floor":   (lambda u, v: np.stack([u, 0 * u, v], -1), (0, 1, 0)),
    "ceiling": (lambda u, v: np.stack([u, 0 * u + 1, v], -1), (0, -1, 0)),
    "left":    (lambda u, v: np.stack([0 * u, v, u], -1), (1, 0, 0)),
    "right":   (lambda u, v: np.stack([0 * u + 1, v, u], -1), (-1, 0, 0)),
    "back":    (lambda u, v: np.stack([u, v, 0 * u], -1), (0, 0, 1)),
    "front":   (lambda u, v: np.stack([u, v, 0 * u + 1], -1), (0, 0, -1)),
}


def cube_grid(values_1d):
    """Probes at every (u, v) of values_1d × values_1d on each cube face.
    Returns points (n,3), normals (n,3), face index (n,), u (n,), v (n,)."""
    u, v = np.meshgrid(values_1d, values_1d, indexing="ij")
    u, v = u.ravel(), v.ravel()
    P, Nn, F = [], [], []
    for k, (name, (f, n)) in enumerate(CUBE_FACES.items()):
        P.append(f(u, v))
        Nn.append(np.tile(np.array(n, float), (len(u), 1)))
        F.append(np.full(len(u), k))
    return np.concatenate(P), np.concatenate(Nn), np.concatenate(F), np.tile(u, 6), np.tile(v, 6)


def write_probes(path, points, normals):
    with open(path, "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for p, n in zip(points, normals):
            f.write("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (p[0], p[1], p[2], n[0], n[1], n[2]))


def read_probe_out(path):
    a = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return a[:, :3], a[:, 3:6]


# ---------------------------------------------------------------------------------------------
# Running radbake
# ---------------------------------------------------------------------------------------------

def bake(scene, n, method, probe_csv, workdir, threads=None):
    """One bake; returns (rgb at the probes (k,3), report dict, wall seconds)."""
    tag = "%s_%s_%d" % (os.path.splitext(os.path.basename(scene))[0], method, n)
    out_csv = os.path.join(workdir, tag + ".values.csv")
    report = os.path.join(workdir, tag + ".report.json")
    cmd = [RADBAKE, "bake", scene, "-o", os.path.join(workdir, tag + ".glb"), "--subdivide", str(n),
           "--method", method, "--probe", probe_csv, "--probe-out", out_csv, "-q", "--report", report,
           "--tolerance", TOLERANCE, "--progress", "none"]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.time()
    subprocess.run(cmd, check=True)
    dt = time.time() - t0
    pts, rgb = read_probe_out(out_csv)
    with open(report) as f:
        rep = json.load(f)
    os.remove(os.path.join(workdir, tag + ".glb"))
    return rgb, rep, dt


# ---------------------------------------------------------------------------------------------
# glTF reading (positions of every quad, world space = node-local here: the shared scenes have no
# node transforms on their meshes)
# ---------------------------------------------------------------------------------------------

def gltf_quads(path):
    """Every quad of the file as (mesh name, material name, 4 corners (4,3), normal (3,)).
    Triangle pairs (a,b,c),(a,c,d) are merged back into the quad a,b,c,d."""
    g = json.load(open(path))
    buf = base64.b64decode(g["buffers"][0]["uri"].split(",", 1)[1])

    def acc(i):
        a = g["accessors"][i]
        bv = g["bufferViews"][a["bufferView"]]
        off = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
        ncomp = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
        dt = {5126: np.float32, 5123: np.uint16, 5125: np.uint32, 5121: np.uint8}[a["componentType"]]
        x = np.frombuffer(buf, dtype=dt, count=a["count"] * ncomp, offset=off)
        return x.reshape(-1, ncomp).astype(float) if ncomp > 1 else x.astype(int)

    for node in g["nodes"]:
        assert not any(k in node for k in ("matrix", "scale", "rotation")) or "camera" in node, node
        assert "translation" not in node or "camera" in node, node
    quads = []
    for m in g["meshes"]:
        for p in m["primitives"]:
            assert p.get("mode", 4) == 4
            P = acc(p["attributes"]["POSITION"])
            idx = acc(p["indices"])
            mat = g["materials"][p["material"]]["name"]
            for t in range(0, len(idx), 6):
                a, b, c, a2, c2, d = idx[t:t + 6]
                assert a == a2 and c == c2
                q = P[[a, b, c, d]]
                n = np.cross(q[1] - q[0], q[2] - q[0]) + np.cross(q[2] - q[0], q[3] - q[0])
                quads.append((m["name"], mat, q, n / np.linalg.norm(n)))
    return quads


def bilinear_map(q, s, t):
    """Point at (s, t) in [0,1]² of the bilinear quad q0 q1 q2 q3 (q0 at (0,0), q1 (1,0), q2 (1,1))."""
    s = s[..., None]
    t = t[..., None]
    return (1 - s) * (1 - t) * q[0] + s * (1 - t) * q[1] + s * t * q[2] + (1 - s) * t * q[3]


def bilinear_jacobian(q, s, t):
    s = s[..., None]
    t = t[..., None]
    ds = (1 - t) * (q[1] - q[0]) + t * (q[2] - q[3])
    dt = (1 - s) * (q[3] - q[0]) + s * (q[2] - q[1])
    return np.linalg.norm(np.cross(ds, dt), axis=-1)


def point_in_convex_xz(pts, poly):
    """pts (n,3) inside the convex polygon poly (k,3) projected on the xz plane (either winding)."""
    x, z = pts[:, 0], pts[:, 2]
    signs = []
    k = len(poly)
    for i in range(k):
        ax, az = poly[i][0], poly[i][2]
        bx, bz = poly[(i + 1) % k][0], poly[(i + 1) % k][2]
        signs.append((bx - ax) * (z - az) - (bz - az) * (x - ax))
    s = np.stack(signs)
    return np.all(s > 0, axis=0) | np.all(s < 0, axis=0)


# ---------------------------------------------------------------------------------------------
# Metrics and fits
# ---------------------------------------------------------------------------------------------

def rms(x, w=None):
    x = np.asarray(x, float)
    if w is None:
        return float(np.sqrt(np.mean(x * x)))
    return float(np.sqrt(np.sum(w * x * x) / np.sum(w)))


def rel_rms_error(values, ref, mask, w=None):
    ww = None if w is None else w[mask]
    return rms(values[mask] - ref[mask], ww) / rms(ref[mask], ww)


def fit_slope(n, err):
    """Least-squares slope p of log(err) = c + p·log(h), h = 1/N."""
    h = 1.0 / np.asarray(n, float)
    A = np.vstack([np.log(h), np.ones_like(h)]).T
    p, c = np.linalg.lstsq(A, np.log(np.asarray(err, float)), rcond=None)[0]
    return float(p), float(c)


def observed_order(n1, n2, n3, v1, v2, v3, w=None):
    """Order p from three levels n1 < n2 < n3 assuming v_N = v + C·N^-p pointwise:
    ‖v2 − v1‖ / ‖v3 − v2‖ = (n1^-p − n2^-p) / (n2^-p − n3^-p), solved by bisection."""
    r = rms(v2 - v1, w) / rms(v3 - v2, w)
    f = lambda p: (n1 ** -p - n2 ** -p) / (n2 ** -p - n3 ** -p) - r
    lo, hi = 0.05, 8.0
    if f(lo) * f(hi) > 0:
        return float("nan")
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if f(lo) * f(mid) <= 0:
            hi = mid
        else:
            lo = mid
    return 0.5 * (lo + hi)


def richardson(n1, n2, v1, v2, p):
    """Extrapolate v1 (level n1) and v2 (level n2 > n1) assuming error ∝ N^-p."""
    r = (n2 / n1) ** p
    return (r * v2 - v1) / (r - 1)


# ---------------------------------------------------------------------------------------------
# Reporting
# ---------------------------------------------------------------------------------------------

def machine():
    cpu = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal"):
                mem = "%.0f GiB" % (int(line.split()[1]) / 2 ** 20)
    except OSError:
        pass
    load = ""
    try:
        load = open("/proc/loadavg").read().split()[0]
    except OSError:
        pass
    return "%d cores (`nproc`), %s, %s RAM, %s, load average at start %s, %s UTC" % (
        os.cpu_count(), cpu, mem, platform.platform(), load, time.strftime("%Y-%m-%d %H:%M", time.gmtime()))


def md_table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for r in rows:
        out.append("| " + " | ".join(str(x) for x in r) + " |")
    return "\n".join(out)


def e(x):
    return "—" if x is None or (isinstance(x, float) and math.isnan(x)) else "%.3e" % x
