#!/usr/bin/python3
"""Probe points for the Cycles-vs-radbake benchmark (system python3 + numpy, no Blender).

Splits every quad of the Cornell box into an M x M grid (bilinear in the quad's corners) and writes
  OUT/grid.gltf   the same scene (nodes, materials) with those grid meshes, for Cycles to bake per vertex
  OUT/probes.csv  x,y,z,nx,ny,nz of the probe points (radbake --probe input)
  OUT/probes.npz  the probe points with their region labels
Probe points = the grid vertices strictly inside each face (face edges and corners, where both methods
meet singular geometry, are left out), except the light and floor points under the blocks (inside
the closed blocks, radiance 0). M is odd by default so the probes are NOT radbake's own nodes for
N = 2, 4, 8, 12, 16 (only for N = 1 at none).
Usage: make_probes.py SCENE.gltf OUTDIR [M]
"""
import base64, json, sys
import numpy as np

scene_path, out = sys.argv[1], sys.argv[2]
M = int(sys.argv[3]) if len(sys.argv) > 3 else 13
g = json.load(open(scene_path))
buf = base64.b64decode(g["buffers"][0]["uri"].split(",", 1)[1])

def acc(i):
    a = g["accessors"][i]; bv = g["bufferViews"][a["bufferView"]]
    n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3}[a["type"]]
    dt = {5126: np.float32, 5123: np.uint16, 5125: np.uint32}[a["componentType"]]
    off = bv.get("byteOffset", 0) + a.get("byteOffset", 0)
    return np.frombuffer(buf, dt, a["count"] * n, off).reshape(a["count"], n).squeeze()

# The scene has no node transforms on meshes (checked below), so mesh space = world space.
for nd in g["nodes"]:
    assert not any(k in nd for k in ("matrix", "translation", "rotation", "scale")) or "mesh" not in nd

def quads(P, I):
    """Triangle pairs (a,b,c),(a,c,d) of the scene -> quads a,b,c,d."""
    T = I.reshape(-1, 3); qs = []
    for t in range(0, len(T), 2):
        t0, t1 = T[t], T[t + 1]
        shared = [v for v in t0 if v in t1]; assert len(shared) == 2
        a = [v for v in t0 if v not in shared][0]; c = [v for v in t1 if v not in shared][0]
        i = list(t0).index(a)
        b = t0[(i + 1) % 3]; d = t0[(i + 2) % 3]      # a,b,d in t0's order; c opposite a
        qs.append((a, b, c, d))
    return qs

mesh_name = {nd["mesh"]: nd["name"] for nd in g["nodes"] if "mesh" in nd}
# footprints of the blocks on the floor (the blocks have no bottoms: inside them radiance is 0)
footprints = {}
blobs, new_acc, new_bv, new_meshes = [], [], [], []
probe_P, probe_N, probe_region, probe_face, probe_W = [], [], [], [], []
offset = 0
def add(arr, target=None):
    global offset
    b = arr.tobytes(); pad = (-len(b)) % 4
    new_bv.append({"buffer": 0, "byteOffset": offset, "byteLength": len(b), **({"target": target} if target else {})})
    blobs.append(b + b"\0" * pad); offset += len(b) + pad
    return len(new_bv) - 1

u = np.linspace(0.0, 1.0, M + 1)
UU, VV = np.meshgrid(u, u, indexing="ij")           # (M+1)^2, i along a->b, j along a->d
for mi, mesh in enumerate(g["meshes"]):
    name = mesh_name[mi]
    prims = []
    for prim in mesh["primitives"]:
        P = acc(prim["attributes"]["POSITION"]).astype(np.float64)
        I = acc(prim["indices"]).astype(np.int64)
        if name in ("short_block", "tall_block"):
            top = P[np.isclose(P[:, 1], P[:, 1].max())]
            footprints[name] = np.unique(np.round(top[:, [0, 2]], 6), axis=0)
        Ps, Ns, Is = [], [], []
        base = 0
        for fi, (a, b, c, d) in enumerate(quads(P, I)):
            A, B, C, D = P[a], P[b], P[c], P[d]
            X = ((1 - UU)[..., None] * (1 - VV)[..., None] * A + UU[..., None] * (1 - VV)[..., None] * B
                 + UU[..., None] * VV[..., None] * C + (1 - UU)[..., None] * VV[..., None] * D)
            n = np.cross(C - A, D - B); n /= np.linalg.norm(n)   # quad normal (diagonals)
            Ps.append(X.reshape(-1, 3)); Ns.append(np.tile(n, ((M + 1) ** 2, 1)))
            k = lambda i, j: base + i * (M + 1) + j
            for i in range(M):
                for j in range(M):   # a->b then a->d is counter-clockwise seen from the front, as in the source
                    Is += [k(i, j), k(i + 1, j), k(i + 1, j + 1), k(i, j), k(i + 1, j + 1), k(i, j + 1)]
            base += (M + 1) ** 2
            inner = X[1:M, 1:M].reshape(-1, 3)
            Ui, Vi = UU[1:M, 1:M].reshape(-1, 1), VV[1:M, 1:M].reshape(-1, 1)
            du = (1 - Vi) * (B - A) + Vi * (C - D); dv = (1 - Ui) * (D - A) + Ui * (C - B)
            area = np.linalg.norm(np.cross(du, dv), axis=1) / M**2     # surface area each probe stands for
            if name != "light":
                probe_W.append(area)
                probe_P.append(inner); probe_N.append(np.tile(n, (len(inner), 1)))
                probe_region += [name] * len(inner); probe_face += [f"{name}/{fi}"] * len(inner)
        Pa = np.concatenate(Ps).astype(np.float32); Na = np.concatenate(Ns).astype(np.float32)
        Ia = np.array(Is, np.uint32)
        # check the winding: a grid triangle's geometric normal must agree with the quad normal
        t = Ia[:3]; gn = np.cross(Pa[t[1]] - Pa[t[0]], Pa[t[2]] - Pa[t[0]])
        assert np.dot(gn, Na[t[0]]) > 0, name
        acc_base = len(new_acc)
        new_acc.append({"bufferView": add(Pa, 34962), "componentType": 5126, "count": len(Pa), "type": "VEC3",
                        "min": Pa.min(0).tolist(), "max": Pa.max(0).tolist()})
        new_acc.append({"bufferView": add(Na, 34962), "componentType": 5126, "count": len(Na), "type": "VEC3"})
        new_acc.append({"bufferView": add(Ia, 34963), "componentType": 5125, "count": len(Ia), "type": "SCALAR"})
        prims.append({"attributes": {"POSITION": acc_base, "NORMAL": acc_base + 1}, "indices": acc_base + 2,
                      "material": prim["material"]})
    new_meshes.append({"name": mesh["name"], "primitives": prims})

data = b"".join(blobs)
g2 = {k: v for k, v in g.items() if k not in ("buffers", "bufferViews", "accessors", "meshes")}
g2["asset"] = dict(g["asset"], generator="radbake bench/cycles/make_probes.py")
g2["meshes"] = new_meshes; g2["accessors"] = new_acc; g2["bufferViews"] = new_bv
g2["buffers"] = [{"byteLength": len(data), "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}]
json.dump(g2, open(f"{out}/grid.gltf", "w"))

P = np.concatenate(probe_P); N = np.concatenate(probe_N); W = np.concatenate(probe_W)
region = np.array(probe_region); face = np.array(probe_face)

def inside(poly, xz):
    # convex polygon: order the footprint corners by angle, then all cross products positive
    c = poly.mean(0); o = np.argsort(np.arctan2(poly[:, 1] - c[1], poly[:, 0] - c[0])); q = poly[o]
    ok = np.ones(len(xz), bool)
    for k in range(len(q)):
        e = q[(k + 1) % len(q)] - q[k]; r = xz - q[k]
        ok &= (e[0] * r[:, 1] - e[1] * r[:, 0]) > 0
    return ok
under = np.zeros(len(P), bool)
fl = region == "floor"
for fp in footprints.values():
    # points within 1 mm of a block wall count as under it too (the junction is singular)
    c = fp.mean(0); grown = c + (fp - c) * (1 + 0.002 / np.linalg.norm(fp - c, axis=1)[:, None])
    under[fl] |= inside(grown, P[fl][:, [0, 2]])
keep = ~under
P, N, W, region, face = P[keep], N[keep], W[keep], region[keep], face[keep]
# distance (in the floor plane) from each probe to the nearest block base edge (inf off the floor)
def seg_dist(xz, a, b):
    t = np.clip(((xz - a) @ (b - a)) / ((b - a) @ (b - a)), 0, 1)
    return np.linalg.norm(xz - (a + t[:, None] * (b - a)), axis=1)
block_dist = np.full(len(P), np.inf); fl = region == "floor"
for fp in footprints.values():
    c = fp.mean(0); q = fp[np.argsort(np.arctan2(fp[:, 1] - c[1], fp[:, 0] - c[0]))]
    for k in range(len(q)):
        block_dist[fl] = np.minimum(block_dist[fl], seg_dist(P[fl][:, [0, 2]], q[k], q[(k + 1) % len(q)]))
np.savez(f"{out}/probes.npz", P=P, N=N, W=W, region=region, face=face, M=M, block_dist=block_dist,
         under_blocks=int(under.sum()))
with open(f"{out}/probes.csv", "w") as f:
    f.write("x,y,z,nx,ny,nz\n")
    for p, n in zip(P, N):
        f.write(",".join(f"{v:.9g}" for v in (*p, *n)) + "\n")
print(f"grid M={M}: {sum(len(p['attributes']) and new_acc[p['attributes']['POSITION']]['count'] for m in new_meshes for p in m['primitives'])} "
      f"grid vertices; {len(P)} probe points ({under.sum()} floor points under the blocks left out)")
