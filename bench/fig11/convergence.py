"""Convergence order of the bilinear and constant methods, dense-grid point error, on
floor_emitter_cube.gltf and cornell_box.gltf. Run through bench/fig11/convergence.sh.

floor_emitter_cube: 64×64 cell-centre probes per face (as fig11.py); main metric over the five
  non-emitting faces (the floor emits); reference bilinear N = 32, 48 Richardson (order 2), checked
  with N = 24 and against cube_radiosity.json (floor_emitter continuous face averages).
cornell_box: 32×32 probes at cell centres (2i+1)/64 of the bilinear parameters of every input quad
  (floor without the block footprints; the light excluded), each weighted by its area (Jacobian),
  luminance Y = 0.2126 R + 0.7152 G + 0.0722 B; reference bilinear N = 24 (plain; the contact of
  the blocks with the floor and the shadow boundaries are not smooth, so no Richardson), checked
  with N = 12 and 16.
"""
import json
import os
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import common as C  # noqa: E402

import matplotlib  # noqa: E402
matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

QUICK = bool(os.environ.get("FIG11_QUICK"))
Y = np.array([0.2126, 0.7152, 0.0722])


def plot(path, title, series, ylabel):
    fig, ax = plt.subplots(figsize=(7, 5))
    for (label, ns, errs, fit, fitrange, style) in series:
        h = 1.0 / np.asarray(ns, float)
        ax.loglog(h, errs, style, ms=4, label="%s: slope %.2f (fit N = %d…%d)" % (label, fit[0], fitrange[0], fitrange[-1]))
        hf = 1.0 / np.asarray(fitrange, float)
        ax.loglog(hf, np.exp(fit[1]) * hf ** fit[0], ":", color=ax.lines[-1].get_color(), lw=1)
    ax.set_xlabel("h = 1/N (patch size / face size)")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ------------------------------------------------------------------------------------------------
def floor_emitter(work, md):
    scene = os.path.join(C.TEST_DATA, "scenes", "floor_emitter_cube.gltf")
    M = 64
    BIL = [1, 2, 3, 4, 5, 6, 8, 10, 12, 16]
    CON = [1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 24]
    REF = [24, 32, 48]
    FIT = (4, 16)
    if QUICK:
        BIL, CON, REF, FIT = [1, 2], [1, 2, 3], [3, 4, 6], (1, 2)
    R0, R1, R2 = REF
    faces = list(C.CUBE_FACES)
    P, Nn, F, U, V = C.cube_grid(C.cell_centres(M))
    nd = len(P)
    five = F != faces.index("floor")
    six = np.ones(nd, bool)
    cube_corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    away = five & (np.min(np.linalg.norm(P[:, None, :] - cube_corners[None], axis=2), axis=1) > 0.125)
    vals, secs, reps, favg = {}, {}, {}, {}
    for method, levels in (("bilinear", sorted(set(REF + BIL))), ("constant", CON)):
        for n in levels:
            extra = np.arange(n + 1) / n
            p2, n2, _, _, _ = C.cube_grid(extra)
            path = os.path.join(work, "fe_probes_%d.csv" % n)
            if method == "bilinear":
                C.write_probes(path, np.concatenate([P, p2]), np.concatenate([Nn, n2]))
            else:
                C.write_probes(path, P, Nn)
            rgb, rep, dt = C.bake(scene, n, method, path, work)
            vals[(method, n)] = rgb[:nd, 0]
            secs[(method, n)], reps[(method, n)] = dt, rep
            if method == "bilinear":
                Wv = rgb[nd:, 0].reshape(6, n + 1, n + 1)
                w = np.ones(n + 1)
                w[0] = w[-1] = 0.5
                favg[n] = [float(w @ Wv[f] @ w) / n ** 2 for f in range(6)]
            C.log("  floor_emitter %-8s N=%2d  %.1f s  iterations %d" % (method, n, dt, rep["solver"]["iterations"]))
    r0, r1, r2 = (vals[("bilinear", n)] for n in REF)
    ref = C.richardson(R1, R2, r1, r2, 2.0)
    p_obs = C.observed_order(R0, R1, R2, r0[five], r1[five], r2[five])
    rr = C.rel_rms_error
    err = {k: rr(v, ref, five) for k, v in vals.items()}
    err6 = {k: rr(v, ref, six) for k, v in vals.items()}
    erra = {k: rr(v, ref, away) for k, v in vals.items()}
    cont = json.load(open(os.path.join(C.TEST_DATA, "reference", "cube_radiosity.json")))["floor_emitter"]["continuous"]["face_average"]
    fr = [C.richardson(R1, R2, favg[R1][f], favg[R2][f], 2.0) for f in range(6)]
    fits = {}
    for method, levels in (("bilinear", BIL), ("constant", CON)):
        sel = [n for n in levels if FIT[0] <= n <= FIT[1]]
        fits[method] = (C.fit_slope(sel, [err[(method, n)] for n in sel]), sel,
                        C.fit_slope(sel, [err6[(method, n)] for n in sel]),
                        C.fit_slope(sel, [erra[(method, n)] for n in sel]))
    md.append("## floor_emitter_cube\n")
    md.append("- probes: %d×%d cell centres (2i+1)/%d per face; error = RMS(L − L_ref)/RMS(L_ref) over the five non-emitting faces "
              "(ceiling and four walls; the emitting floor, L = 1 + reflected, in the 6-face column); one channel (grey scene)" % (M, M, 2 * M))
    md.append("- reference: bilinear N = %d and %d, Richardson pointwise with order 2\n" % (R1, R2))
    md.append(C.md_table(["reference check", "rel. RMS diff (5 faces)"], [
        ["bilinear %d vs %d" % (R0, R1), C.e(rr(r0, r1, five))],
        ["bilinear %d vs %d" % (R1, R2), C.e(rr(r1, r2, five))],
        ["bilinear %d vs reference" % R2, C.e(rr(r2, ref, five))],
        ["reference with the observed order %.2f vs order 2" % p_obs, C.e(rr(C.richardson(R1, R2, r1, r2, p_obs), ref, five))],
    ]))
    md.append("\nFace averages of the bilinear solution (exact integral of the interpolant) against cube_radiosity.json `floor_emitter.continuous`:\n")
    md.append(C.md_table(["face", "continuous", "bilinear N = %d" % R2, "Richardson %d/%d" % (R1, R2)],
                         [[f, "%.6f" % cont[f], "%.6f (%+.1e)" % (favg[R2][i], favg[R2][i] / cont[f] - 1),
                           "%.6f (%+.1e)" % (fr[i], fr[i] / cont[f] - 1)] for i, f in enumerate(faces)]))
    md.append("\nInvariant: mean of L over the six faces = 1/3: " + ", ".join("N = %d: %.6f" % (n, np.mean(favg[n])) for n in REF) + "\n")
    rows = []
    for method, levels in (("bilinear", BIL), ("constant", CON)):
        for n in levels:
            rows.append([method, n, 6 * n * n, C.e(err[(method, n)]), C.e(err6[(method, n)]), C.e(erra[(method, n)]), "%.1f" % secs[(method, n)]])
    md.append(C.md_table(["method", "N", "patches", "rel. RMS error (5 faces)", "6 faces",
                          "5 faces, > 1/8 from every cube corner (%.0f%% of their area)" % (100.0 * away.sum() / five.sum()), "bake s"], rows))
    md.append("\nFitted slope of log(error) vs log(h), N = %d…%d: **bilinear %.2f, constant %.2f** (6 faces: bilinear %.2f, constant %.2f; away from the corners: bilinear %.2f, constant %.2f)\n" % (
        FIT[0], FIT[1], fits["bilinear"][0][0], fits["constant"][0][0], fits["bilinear"][2][0], fits["constant"][2][0],
        fits["bilinear"][3][0], fits["constant"][3][0]))
    # local slopes between consecutive levels (bilinear) to show whether the order settles
    loc = []
    for a, b in zip(BIL[:-1], BIL[1:]):
        loc.append("%d→%d: %.2f" % (a, b, np.log(err[("bilinear", a)] / err[("bilinear", b)]) / np.log(b / a)))
    md.append("Local bilinear slopes: " + ", ".join(loc) + "\n")
    plot(os.path.join(C.IMAGES, "convergence_floor_emitter.png"), "floor_emitter_cube: dense-grid point error",
         [("bilinear", BIL, [err[("bilinear", n)] for n in BIL], fits["bilinear"][0], fits["bilinear"][1], "o-"),
          ("constant", CON, [err[("constant", n)] for n in CON], fits["constant"][0], fits["constant"][1], "s-"),
          ("bilinear, away from corners", BIL, [erra[("bilinear", n)] for n in BIL], fits["bilinear"][3], fits["bilinear"][1], "o--"),
          ("constant, away from corners", CON, [erra[("constant", n)] for n in CON], fits["constant"][3], fits["constant"][1], "s--")],
         "relative RMS point error (5 non-emitting faces)")
    return fits


# ------------------------------------------------------------------------------------------------
def cornell(work, md):
    scene = os.path.join(C.TEST_DATA, "scenes", "cornell_box.gltf")
    M = 32
    BIL = [1, 2, 3, 4, 6, 8, 12]
    CON = [1, 2, 3, 4, 6, 8, 12]
    REF = [12, 16, 24]      # 12 is also a test level
    FIT = (2, 8)
    if QUICK:
        BIL, CON, REF, FIT = [1, 2], [1, 2], [2, 3, 4], (1, 2)
    quads = C.gltf_quads(scene)
    s = C.cell_centres(M)
    S, T = np.meshgrid(s, s, indexing="ij")
    S, T = S.ravel(), T.ravel()
    blocks = {}
    for name, mat, q, n in quads:
        if name.endswith("_block") and n[1] > 0.9:   # block top: its footprint on the floor
            blocks[name] = q
    pts, nrm, wts, part = [], [], [], []
    for name, mat, q, n in quads:
        if mat == "light":
            continue
        p = C.bilinear_map(q, S, T)
        w = C.bilinear_jacobian(q, S, T) / M ** 2
        keep = np.ones(len(p), bool)
        if name == "floor":
            for b in blocks.values():
                keep &= ~C.point_in_convex_xz(p, b)
        pts.append(p[keep])
        nrm.append(np.tile(n, (keep.sum(), 1)))
        wts.append(w[keep])
        part.append(np.full(keep.sum(), name))
    P, Nn, W, part = np.concatenate(pts), np.concatenate(nrm), np.concatenate(wts), np.concatenate(part)
    path = os.path.join(work, "cornell_probes.csv")
    C.write_probes(path, P, Nn)
    allm = np.ones(len(P), bool)
    nofloor = part != "floor"
    vals, secs = {}, {}
    for method, levels in (("bilinear", sorted(set(REF + BIL))), ("constant", CON)):
        for n in levels:
            rgb, rep, dt = C.bake(scene, n, method, path, work)
            vals[(method, n)] = rgb @ Y
            secs[(method, n)] = dt
            C.log("  cornell %-8s N=%2d  %.1f s  iterations %d  patches %d  matrixFree %s" % (
                method, n, dt, rep["solver"]["iterations"], rep["counts"]["patches"], rep["solver"]["matrixFree"]))
    r0, r1, ref = (vals[("bilinear", n)] for n in REF)
    R0, R1, R2 = REF
    rr = C.rel_rms_error
    err = {k: rr(v, ref, allm, W) for k, v in vals.items()}
    errnf = {k: rr(v, ref, nofloor, W) for k, v in vals.items()}
    p_obs = C.observed_order(R0, R1, R2, r0, r1, ref, W)
    p_obs_nf = C.observed_order(R0, R1, R2, r0[nofloor], r1[nofloor], ref[nofloor], W[nofloor])
    fits = {}
    for method, levels in (("bilinear", BIL), ("constant", CON)):
        sel = [n for n in levels if FIT[0] <= n <= FIT[1]]
        fits[method] = (C.fit_slope(sel, [err[(method, n)] for n in sel]), sel,
                        C.fit_slope(sel, [errnf[(method, n)] for n in sel]))
    md.append("## cornell_box\n")
    md.append("- probes: %d on %d input quads (%d×%d cell centres of each quad's bilinear parameters (2i+1)/%d, floor points inside the "
              "block footprints dropped, the light excluded), each weighted by its area; error = area-weighted RMS(Y − Y_ref)/RMS(Y_ref), "
              "Y = 0.2126 R + 0.7152 G + 0.0722 B (linear)" % (len(P), len(quads) - 1, M, M, 2 * M))
    md.append("- reference: bilinear N = %d, plain (no extrapolation: the solution is not smooth at the block-floor contact "
              "lines and shadow boundaries, which the uniform mesh does not follow)\n" % R2)
    md.append(C.md_table(["reference check", "all surfaces", "without the floor"], [
        ["bilinear %d vs %d" % (R0, R1), C.e(rr(r0, r1, allm, W)), C.e(rr(r0[nofloor], r1[nofloor], allm[nofloor], W[nofloor]))],
        ["bilinear %d vs %d" % (R1, R2), C.e(rr(r1, ref, allm, W)), C.e(rr(r1[nofloor], ref[nofloor], allm[nofloor], W[nofloor]))],
        ["observed order from %d, %d, %d" % (R0, R1, R2), "%.2f" % p_obs, "%.2f" % p_obs_nf],
        ["estimated error of the reference, ‖L%d − L%d‖/((%d/%d)^p − 1)" % (R2, R1, R2, R1),
         C.e(rr(r1, ref, allm, W) / ((R2 / R1) ** p_obs - 1)),
         C.e(rr(r1[nofloor], ref[nofloor], allm[nofloor], W[nofloor]) / ((R2 / R1) ** p_obs_nf - 1))],
    ]))
    md.append("\nProbes whose reference luminance is 0 (would mean a probe off its surface or in an occluded spot): %d; "
              "smallest reference Y %.3g, largest %.3g.\n" % (int(np.sum(ref <= 0)), float(ref.min()), float(ref.max())))
    rows = []
    for method, levels in (("bilinear", BIL), ("constant", CON)):
        for n in levels:
            rows.append([method, n, C.e(err[(method, n)]), C.e(errnf[(method, n)]), "%.1f" % secs[(method, n)]])
    md.append(C.md_table(["method", "N", "rel. RMS error (all surfaces)", "without the floor", "bake s"], rows))
    md.append("\nFitted slope of log(error) vs log(h), N = %d…%d: **bilinear %.2f, constant %.2f** (without the floor: bilinear %.2f, constant %.2f)\n" % (
        FIT[0], FIT[1], fits["bilinear"][0][0], fits["constant"][0][0], fits["bilinear"][2][0], fits["constant"][2][0]))
    plot(os.path.join(C.IMAGES, "convergence_cornell.png"), "cornell_box: dense-grid point error (luminance)",
         [("bilinear, all", BIL, [err[("bilinear", n)] for n in BIL], fits["bilinear"][0], fits["bilinear"][1], "o-"),
          ("constant, all", CON, [err[("constant", n)] for n in CON], fits["constant"][0], fits["constant"][1], "s-"),
          ("bilinear, no floor", BIL, [errnf[("bilinear", n)] for n in BIL], fits["bilinear"][2], fits["bilinear"][1], "o--"),
          ("constant, no floor", CON, [errnf[("constant", n)] for n in CON], fits["constant"][2], fits["constant"][1], "s--")],
         "relative RMS point error (area-weighted, luminance)")
    return fits


def main():
    t0 = time.time()
    os.makedirs(C.OUT, exist_ok=True)
    os.makedirs(C.IMAGES, exist_ok=True)
    work = tempfile.mkdtemp(prefix="convergence_")
    mach = C.machine()
    C.log("machine:", mach)
    body = []
    floor_emitter(work, body)
    cornell(work, body)
    total = time.time() - t0
    md = ["# Convergence order, dense-grid point error\n",
          "Generated by `bench/fig11/convergence.sh` (do not edit by hand).\n",
          "- machine: " + mach,
          "- total run time: %.0f s (%.1f min)" % (total, total / 60),
          "- radbake `--tolerance %s`; slopes are least-squares fits of log(error) against log(h), h = 1/N; "
          "plots `docs/images/convergence_floor_emitter.png`, `docs/images/convergence_cornell.png`\n" % C.TOLERANCE] + body
    text = "\n".join(md)
    with open(os.path.join(C.OUT, "convergence.md"), "w") as f:
        f.write(text)
    print(text)
    import shutil
    shutil.rmtree(work)


if __name__ == "__main__":
    main()
