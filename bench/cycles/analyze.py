#!/usr/bin/python3
"""Errors, tables and the plot for bench/cycles/run.sh (system python3: numpy, scipy, matplotlib).

Usage: analyze.py OUTDIR PNG
Reads OUTDIR/probes.npz, OUTDIR/meta.json, OUTDIR/radbake/N*.{csv,json,time} (uniform) and R*.{csv,json,time}
(R<N>_<B>: --subdivide N --refine at a budget of B patches), OUTDIR/cycles/*.{npz,time};
writes OUTDIR/results.md (also printed) and OUTDIR/results.json, and the plot PNG.
"""
import glob, json, os, re, sys
import numpy as np
from scipy.spatial import cKDTree

out, png = sys.argv[1], sys.argv[2]
meta = json.load(open(f"{out}/meta.json"))
pr = np.load(f"{out}/probes.npz")
P, Nrm, region = pr["P"], pr["N"], pr["region"]
face = pr["face"]; M = int(pr["M"])
W = pr["W"] / pr["W"].sum()   # area each probe stands for, normalised
block_dist = pr["block_dist"]


def tm(path):
    e, u, s = map(float, open(path).read().split()[:3]); return e, u + s

# --- radbake -------------------------------------------------------------------------------
rb = {}
for f in glob.glob(f"{out}/radbake/N*.csv"):
    n = int(re.search(r"N(\d+)\.csv", f).group(1))
    v = np.loadtxt(f, delimiter=",", skiprows=1)
    assert np.abs(v[:, :3] - P).max() < 1e-6
    rep = json.load(open(f"{out}/radbake/N{n}.json"))
    wall, cpu = tm(f"{out}/radbake/N{n}.time")
    rb[n] = dict(L=v[:, 3:], total=rep["timings"]["total"], solve=rep["timings"]["solve"], wall=wall, cpu=cpu,
                 unknowns=rep["counts"]["vertices"], patches=rep["counts"]["patches"])

# radbake --subdivide N --refine at --max-patches B: R<N>_<B>.*
rf = {}
for f in glob.glob(f"{out}/radbake/R*.csv"):
    tag = re.search(r"R(\d+_\d+)\.csv", f).group(1)
    v = np.loadtxt(f, delimiter=",", skiprows=1)
    assert np.abs(v[:, :3] - P).max() < 1e-6
    rep = json.load(open(f"{out}/radbake/R{tag}.json"))
    wall, cpu = tm(f"{out}/radbake/R{tag}.time")
    rf[tuple(int(x) for x in tag.split("_"))] = dict(L=v[:, 3:], total=rep["timings"]["total"], refine=rep["timings"]["tessellate"], wall=wall,
                          cpu=cpu, unknowns=rep["counts"]["vertices"], patches=rep["counts"]["patches"],
                          budget=rep["refinement"]["budgetReached"], target=rep["refinement"]["target"])

# --- Cycles: match the bake's vertices to the probes (position, then normal) -----------------
def cycles_at_probes(path):
    c = np.load(path)
    dist, cand = cKDTree(c["pos"]).query(P, k=8)
    idx = np.array([ci[np.argmax(c["nrm"][ci] @ n - 1e3 * (di > 1e-5))] for ci, di, n in zip(cand, dist, Nrm)])
    assert dist.min(1).max() < 1e-5 and (c["nrm"][idx] * Nrm).sum(1).min() > 0.99
    return c["L"][idx].astype(np.float64), float(c["bake_wall"]), float(c["bake_cpu"]), int(c["samples"])
cy, cyref = {}, []
for f in sorted(glob.glob(f"{out}/cycles/*.npz")):
    name = os.path.basename(f)[:-4]
    L, bw, bc, spp = cycles_at_probes(f)
    wall, cpu = tm(f[:-4] + ".time")
    rec = dict(L=L, bake_wall=bw, bake_cpu=bc, wall=wall, cpu=cpu, samples=spp)
    if name.startswith("ref"): cyref.append(rec)
    else: cy[rec["samples"]] = rec

# --- reference ----------------------------------------------------------------------------
NA, NB = meta["ref_levels"]                         # e.g. 16, 32: Richardson extrapolation (h^2)
r = NB / NA
LA, LB = rb[NA]["L"], rb[NB]["L"]
L_rich = LB + (LB - LA) / (r * r - 1)
corr = np.abs(L_rich - LB).max(1) / LB.mean(1)   # size of the extrapolation step, relative to brightness
L_cy = np.mean([c["L"] for c in cyref], axis=0)
S_ref = cyref[0]["samples"]; nref = len(cyref)
# Cycles noise of the mean of the reference runs, per point and channel: |a-b|/2 for two runs
noise = np.abs(cyref[0]["L"] - cyref[1]["L"]) / 2 if nref == 2 else None
TAU = meta.get("tau", 0.0025)
conv = corr <= TAU          # radbake converged here: its Richardson step is at most TAU relative
ref = np.where(conv[:, None], L_rich, L_cy)
src = np.where(conv, "radbake", "Cycles")

NORM = ref.mean(1, keepdims=True)           # a point's brightness: mean of the reference's RGB
# variance of the reference at each point: 0 where it is radbake's extrapolation, the Cycles mean's
# sampling variance (|a - b|^2 / 4, unbiased for two independent runs) where it is Cycles'
VREF = np.where(conv[:, None], 0.0, (cyref[0]["L"] - cyref[1]["L"]) ** 2 / 4)

def rms(L, w=W, m=None, R=None, per_channel=False, correct=True):
    """RMS over points (weights w) and channels of (L - R) / brightness(R); with per_channel, / R per channel.
    Against the hybrid reference, the reference's own sampling variance is subtracted (unbiased MSE)."""
    hyb = R is None
    R = ref if R is None else R
    den = R if per_channel else R.mean(1, keepdims=True)
    e2 = ((L - R) / den) ** 2
    if hyb and correct: e2 = e2 - VREF / den ** 2
    if m is not None: e2, w = e2[m], w[m]
    w = w / w.sum()
    return float(np.sqrt(max((w[:, None] * e2).sum() / 3, 0.0)))
def rms_unw(L, m=None):
    return rms(L, np.full(len(P), 1.0 / len(P)), m)

lines = []
pl = lambda s="": lines.append(s)
pl("# Cycles bake vs radbake: accuracy against time (Cornell box)")
pl()
pl(f"Generated by `bench/cycles/run.sh` on {meta['date']}. Machine: {meta['nproc']} cores, {meta['cpu']}; "
   f"{meta['blender']}; radbake {meta['radbake']} ({meta['radbake_build']}).")
pl(f"Load average before / after the run: {meta['load_before']} / {meta.get('load_after', '?')} "
   f"(**timings were taken under whatever other load there was**; wall and CPU time are both recorded; "
   f"rerun `bench/cycles/run.sh` on an idle machine for clean numbers). Whole script: {meta.get('script_seconds', '?')} s.")
pl()
pl(f"Probe points: {len(P)} points, the inner vertices of an M = {M} grid on every face of "
   f"`cornell_box.gltf` (face edges, the light, and {int(pr['under_blocks'])} floor points inside the blocks' footprints "
   f"left out). M = {M} is odd, so the probes are not radbake's own nodes at N = 2…16. Cycles bakes on a copy of the "
   f"scene whose mesh vertices are exactly these grid points (POINT-domain FLOAT_COLOR bake); radbake evaluates "
   f"them with `--probe`.")
pl()
# agreement
both = conv
d = (L_cy - L_rich) / L_rich.mean(1, keepdims=True)          # per channel, relative to the point's brightness
vn = (cyref[0]["L"] - cyref[1]["L"]) ** 2 / 4 / L_rich.mean(1, keepdims=True) ** 2
pl("## Reference and its validation")
pl()
pl(f"- radbake reference: Richardson extrapolation (h²) of N = {NA} and N = {NB}: "
   f"L_ref = L_{NB} + (L_{NB} − L_{NA})/({r:g}² − 1). Its step |L_ref − L_{NB}| (relative to the point's brightness) is "
   f"≤ {TAU:.2%} at {conv.sum()} of {len(P)} points ({W[conv].sum():.1%} of the area); median {np.median(corr):.2%}, "
   f"90th percentile {np.percentile(corr, 90):.2%}, largest {corr.max():.1%}.")
pl(f"- Cycles reference: mean of {nref} runs at {S_ref} samples (seeds 1, 2). Sampling noise of that mean, "
   f"estimated per point as |a − b|/2: RMS {np.sqrt((W[:, None] * vn).sum() / 3):.2%} (area-weighted, relative to brightness).")
pl(f"- **Reference used**: radbake's extrapolation where its step is ≤ {TAU:.2%}, Cycles' mean at the other "
   f"{(~conv).sum()} points ({W[~conv].sum():.1%} of the area; "
   + ", ".join(f"{k} {v}" for k, v in zip(*np.unique(region[~conv], return_counts=True))) + "). "
   "At those points the reference's own sampling variance (|a − b|²/4 per channel) is subtracted from the squared "
   "errors, so the RMS errors below are unbiased estimates of the error against the noise-free answer.")
pl(f"- Error measure: for each point and RGB channel (L − L_ref)/brightness(L_ref), brightness = mean of the "
   f"reference's R, G, B; RMS over points (each weighted by the surface area it stands for) and channels. The "
   f"'per channel' column divides by L_ref of the channel instead (dim channels, e.g. blue on the red wall, weigh more).")
pl()
pl(f"Agreement of the two independent references where radbake is converged ({both.sum()} points), "
   f"(Cycles − radbake)/brightness:")
pl()
pl("| region | points | mean R | mean G | mean B | ± (std. error of a mean) | RMS difference | RMS expected from Cycles' noise alone | max abs |")
pl("|---|---|---|---|---|---|---|---|---|")
agree = {}
def agree_row(name, m):
    m = m & both
    if not m.any(): return
    dm = d[m]; se = dm.std(0).mean() / np.sqrt(m.sum())
    agree[name] = dict(points=int(m.sum()), mean=dm.mean(0).tolist(), se=float(se), rms=float(np.sqrt((dm**2).mean())),
                       rms_noise=float(np.sqrt(vn[m].mean())), max=float(np.abs(dm).max()))
    pl(f"| {name} | {m.sum()} | {dm[:,0].mean():+.2%} | {dm[:,1].mean():+.2%} | {dm[:,2].mean():+.2%} | {se:.2%} | "
       f"{np.sqrt((dm**2).mean()):.2%} | {np.sqrt(vn[m].mean()):.2%} | {np.abs(dm).max():.2%} |")
for rg in np.unique(region):
    agree_row(rg, region == rg)
agree_row("**all**", np.ones(len(P), bool))
pl()
pl("If the two agree, the mean differences are within a few standard errors of 0 and the RMS difference matches "
   "what Cycles' noise alone explains.")
pl()
conv_lines = []
# radbake self-convergence
pl("radbake convergence at the probe points (area-weighted RMS relative change between levels):")
pl()
pl("| levels | RMS change | RMS change at the points where the reference is radbake's |")
pl("|---|---|---|")
lv = sorted(rb)
for a, b in zip(lv, lv[1:]):
    pl(f"| {a} → {b} | {rms(rb[b]['L'], R=rb[a]['L']):.2%} | {rms(rb[b]['L'], R=rb[a]['L'], m=conv):.2%} |")
pl(f"| {NB} → extrapolated | {rms(L_rich, R=LB):.2%} | {rms(L_rich, R=LB, m=conv):.2%} |")
pl()

# --- per-run table -------------------------------------------------------------------------
res = {"radbake": [], "cycles": []}
pl("## Runs")
pl()
pl("| method | setting | RMS rel. error | (unweighted) | (per channel) | away from the block–floor contact* | core wall s | core CPU s | command wall s | command CPU s |")
pl("|---|---|---|---|---|---|---|---|---|---|")
# geometric subset: the block-floor contact (floor within 3 cm of a block's base, block sides below 3 cm)
CONTACT = 0.03
strip = (block_dist < CONTACT) | (np.isin(region, ["short_block", "tall_block"]) & (np.abs(Nrm[:, 1]) < 0.5) & (P[:, 1] < CONTACT))
for n in sorted(rb):
    if n == NB: continue                         # the reference's top level
    R = rb[n]; e = rms(R["L"]); eu = rms_unw(R["L"]); es = rms(R["L"], m=~strip); ec = rms(R["L"], per_channel=True)
    res["radbake"].append(dict(N=n, err=e, err_unweighted=eu, err_nostrip=es, total=R["total"], wall=R["wall"],
                               cpu=R["cpu"], unknowns=R["unknowns"]))
    pl(f"| radbake | N = {n} ({R['unknowns']} unknowns) | {e:.2%} | ({eu:.2%}) | ({ec:.2%}) | {es:.2%} | {R['total']:.2f} (report total) | – | {R['wall']:.2f} | {R['cpu']:.2f} |")
res["refine"] = []
for t in sorted(rf):
    R = rf[t]; e = rms(R["L"]); eu = rms_unw(R["L"]); es = rms(R["L"], m=~strip); ec = rms(R["L"], per_channel=True)
    res["refine"].append(dict(target=R["target"], N=t[0], budget=t[1], err=e, err_unweighted=eu, err_nostrip=es, total=R["total"], wall=R["wall"],
                              cpu=R["cpu"], unknowns=R["unknowns"], patches=R["patches"], refine=R["refine"]))
    pl(f"| radbake | --subdivide {t[0]} --refine {R['target']:g} --max-patches {t[1]} ({R['patches']} patches{', budget reached' if R['budget'] else ''}; refining {R['refine']:.1f} s) | {e:.2%} | ({eu:.2%}) | ({ec:.2%}) | {es:.2%} | {R['total']:.2f} (report total) | – | {R['wall']:.2f} | {R['cpu']:.2f} |")
for s in sorted(cy):
    C = cy[s]; e = rms(C["L"]); eu = rms_unw(C["L"]); es = rms(C["L"], m=~strip); ec = rms(C["L"], per_channel=True)
    res["cycles"].append(dict(samples=s, err=e, err_unweighted=eu, err_nostrip=es, bake_wall=C["bake_wall"],
                              bake_cpu=C["bake_cpu"], wall=C["wall"], cpu=C["cpu"]))
    pl(f"| Cycles | {s} samples | {e:.2%} | ({eu:.2%}) | ({ec:.2%}) | {es:.2%} | {C['bake_wall']:.2f} (bake call) | {C['bake_cpu']:.2f} | {C['wall']:.2f} | {C['cpu']:.2f} |")
for C in cyref:
    pl(f"| Cycles (reference run) | {C['samples']} samples | – | – | – | – | {C['bake_wall']:.2f} (bake call) | {C['bake_cpu']:.2f} | {C['wall']:.2f} | {C['cpu']:.2f} |")
pl()
pl(f"\\* leaving out the {strip.sum()} points within {CONTACT * 100:.0f} cm of a block–floor contact line (floor around the blocks, bottoms of the block sides).")
pl(f"N = {NB} serves the reference only; not listed. Core time: radbake's report total (import, tessellation, solve, export); Cycles' `bpy.ops.object.bake` call. Command: the whole process (Blender: start, glTF import, material rewiring, bake, readback).")
pl()

# --- time to reach ------------------------------------------------------------------------
def reach(ts, es, target, extrapolate=True):
    ts, es = np.asarray(ts, float), np.asarray(es, float)
    o = np.argsort(ts); ts, es = ts[o], es[o]
    if es[0] <= target: return ("≤", ts[0])
    for i in range(1, len(ts)):
        if es[i] <= target:
            t = np.exp(np.interp(np.log(target), [np.log(es[i]), np.log(es[i - 1])], [np.log(ts[i]), np.log(ts[i - 1])]))
            return ("", t)
    # not reached: extrapolate the power law err ~ t^k fitted to the last three runs (reported as such);
    # not for the refinement runs, whose starts differ (they are not one curve)
    if not extrapolate: return None
    k, c = np.polyfit(np.log(ts[-3:]), np.log(es[-3:]), 1)
    if k < -0.05:
        return ("~", float(np.exp((np.log(target) - c) / k)), k)
    return None
def ratio(tc, tr):
    if not (tc and tr): return "–"
    r = f"{tc[1] / tr[1]:.2g}×"
    if tc[0] or tr[0]: r = "≈ " + r + " (extrapolated)" * ("~" in (tc[0], tr[0]))
    return r
def fmt(x):
    if x is None: return "not reached"
    if x[0] == "~": return f"not reached; extrapolated ≈ {x[1]:.0f} s (err ∝ t^{x[2]:.2f})"
    return f"{x[0]}{x[1]:.2f} s"
pl("## Time to reach an RMS error (log-log interpolation between measured runs)")
pl()
for label, key, cols in [("core time (Cycles: the bake call; radbake: the report's total)", "core", None),
                         ("whole command (wall)", "wall", None), ("whole command (CPU, user+sys)", "cpu", None)]:
    pl(f"**{label}**")
    pl()
    pl("| target | Cycles | radbake | Cycles / radbake | radbake --refine | Cycles / radbake --refine |")
    pl("|---|---|---|---|---|---|")
    for tgt in (0.02, 0.01, 0.005):
        tc = reach([c["bake_wall" if key == "core" else key] for c in res["cycles"]], [c["err"] for c in res["cycles"]], tgt)
        tr = reach([c["total" if key == "core" else key] for c in res["radbake"]], [c["err"] for c in res["radbake"]], tgt)
        tf = reach([c["total" if key == "core" else key] for c in res["refine"]], [c["err"] for c in res["refine"]], tgt, False) if res["refine"] else None
        pl(f"| {tgt:.1%} | {fmt(tc)} | {fmt(tr)} | {ratio(tc, tr)} | {fmt(tf)} | {ratio(tc, tf)} |")
        res.setdefault("reach", []).append(dict(kind=key, target=tgt, cycles=tc and tc[1], radbake=tr and tr[1], refine=tf and tf[1]))
    pl()
SMOOTH = np.isin(region, ["back_wall", "green_wall", "red_wall", "ceiling"])
for lab, msk, key in [(f"Same, away from the block–floor contact ({strip.sum()} points within {CONTACT * 100:.0f} cm of it left out; core time):", ~strip, "err_nostrip"),
                      (f"Same, walls and ceiling only ({SMOOTH.sum()} points: no shadow boundaries or contact lines; core time):", SMOOTH, "err_smooth")]:
    for x in res["radbake"]: x[key] = rms(rb[x["N"]]["L"], m=msk)
    for x in res["refine"]: x[key] = rms(rf[(x["N"], x["budget"])]["L"], m=msk)
    for x in res["cycles"]: x[key] = rms(cy[x["samples"]]["L"], m=msk)
    pl(lab)
    pl()
    pl("| target | Cycles | radbake | Cycles / radbake | radbake --refine | Cycles / radbake --refine |")
    pl("|---|---|---|---|---|---|")
    for tgt in (0.02, 0.01, 0.005):
        tc = reach([c["bake_wall"] for c in res["cycles"]], [c[key] for c in res["cycles"]], tgt)
        tr = reach([c["total"] for c in res["radbake"]], [c[key] for c in res["radbake"]], tgt)
        tf = reach([c["total"] for c in res["refine"]], [c[key] for c in res["refine"]], tgt, False) if res["refine"] else None
        pl(f"| {tgt:.1%} | {fmt(tc)} | {fmt(tr)} | {ratio(tc, tr)} | {fmt(tf)} | {ratio(tc, tf)} |")
        res.setdefault("reach", []).append(dict(kind=key, target=tgt, cycles=tc and tc[1], radbake=tr and tr[1], refine=tf and tf[1]))
    pl()
pl("| errors of these subsets | " + " | ".join(f"N={x['N']}" for x in res["radbake"]) + " | " + " | ".join(f"N={x['N']} refined to {x['budget']}" for x in res["refine"]) + " | " + " | ".join(f"{x['samples']} spp" for x in res["cycles"]) + " |")
pl("|---" * (1 + len(res["radbake"]) + len(res["refine"]) + len(res["cycles"])) + "|")
for key, lab in [("err_nostrip", "away from contact"), ("err_smooth", "walls + ceiling")]:
    pl(f"| {lab} | " + " | ".join(f"{x[key]:.2%}" for x in res["radbake"] + res["refine"] + res["cycles"]) + " |")
pl()

# per-region errors
pl("## Error by region (area-weighted RMS, relative to brightness)")
pl()
nmax = max(x["N"] for x in res["radbake"]); smax = max(cy)
nmid = 8 if 8 in rb else nmax; smid = 256 if 256 in cy else smax
cols = [("radbake", nmid), ("radbake", nmax)] + [("refine", t) for t in sorted(rf)] + [("Cycles", smid), ("Cycles", smax)]
get = lambda k, v: rb[v]["L"] if k == "radbake" else rf[v]["L"] if k == "refine" else cy[v]["L"]
head = lambda k, v: f"radbake N = {v}" if k == "radbake" else f"radbake N = {v[0]} refined, budget {v[1]}" if k == "refine" else f"Cycles {v} spp"
pl("| region | points | of them radbake-referenced | " + " | ".join(head(k, v) for k, v in cols) + " |")
pl("|---" * (len(cols) + 3) + "|")
for rg in list(np.unique(region)) + ["all"]:
    m = region == rg if rg != "all" else np.ones(len(P), bool)
    pl(f"| {rg} | {m.sum()} | {(m & conv).sum()} | " + " | ".join(f"{rms(get(k, v), m=m):.2%}" for k, v in cols) + " |")
for lab, m in [("points where radbake is not converged", ~conv), (f"within {CONTACT * 100:.0f} cm of the block–floor contact", strip), ("floor within 2 cm of a block", block_dist < 0.02)]:
    if m.any():
        pl(f"| {lab} | {m.sum()} | {(m & conv).sum()} | " + " | ".join(f"{rms(get(k, v), m=m):.2%}" for k, v in cols) + " |")
pl()
fl = block_dist < 0.02
if fl.any():
    dd = ((rb[nmax]["L"] - ref) / ref.mean(1, keepdims=True))[fl].mean(1)
    pl(f"Floor points within 2 cm of a block's base ({fl.sum()}): radbake N = {nmax} is {dd.mean():+.1%} off there on "
       f"average (worst {dd.min():+.0%}). The floor is one input quad; its N × N patches are cut along the blocks' "
       f"footprints (docs/radiosity.md, \"Contact cuts\"), so what is left there is the field's interpolation over "
       f"patches beside the shadowed feet.")
    for t in sorted(rf):
        dd = ((rf[t]["L"] - ref) / ref.mean(1, keepdims=True))[fl].mean(1)
        pl(f"With `--subdivide {t[0]} --refine {rf[t]['target']:g} --max-patches {t[1]}` ({rf[t]['patches']} patches): {dd.mean():+.1%} on average there (worst {dd.min():+.0%}).")
    pl()

md = "\n".join(lines)
open(f"{out}/results.md", "w").write(md + "\n")
json.dump(res, open(f"{out}/results.json", "w"), indent=1, default=float)
print(md)

# --- plot ------------------------------------------------------------------------------------
import matplotlib; matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, ax = plt.subplots(figsize=(7.5, 5.2), dpi=130)
rbr, cyr = res["radbake"], res["cycles"]
ax.loglog([x["total"] for x in rbr], [x["err"] for x in rbr], "o-", color="C0", label="radbake (report total)")
ax.loglog([x["wall"] for x in rbr], [x["err"] for x in rbr], "o--", color="C0", alpha=0.45, mfc="none", label="radbake (whole command)")
for x in rbr: ax.annotate(f"N={x['N']}", (x["total"], x["err"]), textcoords="offset points", xytext=(5, 4), fontsize=8, color="C0")
rfr = res["refine"]
if rfr:
    ax.loglog([x["total"] for x in rfr], [x["err"] for x in rfr], "P-", color="C4", label="radbake --refine (report total)")
    for x in rfr: ax.annotate(f"{x['patches']} p", (x["total"], x["err"]), textcoords="offset points", xytext=(5, -10), fontsize=8, color="C4")
ax.loglog([x["bake_wall"] for x in cyr], [x["err"] for x in cyr], "s-", color="C3", label="Cycles (bake call)")
ax.loglog([x["wall"] for x in cyr], [x["err"] for x in cyr], "s--", color="C3", alpha=0.45, mfc="none", label="Cycles (whole command)")
for x in cyr: ax.annotate(f"{x['samples']} spp", (x["bake_wall"], x["err"]), textcoords="offset points", xytext=(5, 4), fontsize=8, color="C3")
ax.loglog([x["total"] for x in rbr], [x["err_nostrip"] for x in rbr], "^:", color="C0", alpha=0.8, ms=4, label="radbake, away from block-floor contact*")
ax.loglog([x["bake_wall"] for x in cyr], [x["err_nostrip"] for x in cyr], "v:", color="C3", alpha=0.8, ms=4, label="Cycles, away from block-floor contact*")
ax.loglog([x["total"] for x in rbr], [x["err_smooth"] for x in rbr], "D-.", color="C2", alpha=0.9, ms=4, label="radbake, walls + ceiling only")
ax.loglog([x["bake_wall"] for x in cyr], [x["err_smooth"] for x in cyr], "D-.", color="C1", alpha=0.9, ms=4, label="Cycles, walls + ceiling only")
for t in (0.02, 0.01, 0.005): ax.axhline(t, color="0.7", lw=0.8, zorder=0)
ax.set_xlabel("wall time [s] (2 cores; under the load at the time of the run)")
ax.set_ylabel("RMS relative error at the probe points")
ax.set_title(f"Cornell box, {len(P)} surface points: Cycles bake vs radbake\n"
             f"{meta['date'][:10]}, load avg {meta['load_before']}", fontsize=10)
ax.grid(True, which="both", alpha=0.25); ax.legend(fontsize=7.5, loc="upper right")
fig.text(0.01, 0.005, "* without the points within 3 cm of the blocks' contact with the floor.   Reference: radbake N=16/24 extrapolated where\n   converged, else the mean of 2 Cycles runs (its noise subtracted). Error relative to each point's brightness, area-weighted.", fontsize=7)
fig.tight_layout(rect=(0, 0.035, 1, 1)); fig.savefig(png)
