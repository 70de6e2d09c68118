#!/usr/bin/python3
"""Scaling of radbake's bake with patch count, on the Cornell box (subdivided) and the 2CylinderEngine
(parts of it, then all of it with a uniform sky). Driven by bench/scaling/run.sh; see its header.

Small cases are always run; their log-log fit predicts each large case, which is run only when the
prediction fits the per-case and the total time budget (else the prediction is reported, marked as
extrapolated). Every bake records wall time per stage (radbake's --report), CPU time (user + sys)
and peak RSS (/usr/bin/time -v) and the 1-minute load average before and after it.
"""
import argparse
import datetime
import json
import math
import os
import platform
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent.parent
CORNELL = ROOT / "tests" / "data" / "scenes" / "cornell_box.gltf"
ENGINE = ROOT / "tests" / "data" / "assets" / "valid" / "2CylinderEngine" / "2CylinderEngine.glb"
STAGES = ["import", "tessellate", "solve", "export", "total"]
MATRIX_BUDGET = 2 << 30      # RadiosityOptions::matrixMemoryBytes (radiosity/radiosity.h)
BYTES_PER_ENTRY = 12         # kBytesPerEntry: uint32 column + double value (radiosity.cpp)

# Cornell box: 24 input quads, so N gives 24 N² patches.
CORNELL_SMALL = [7, 9, 14, 20]          # 1176, 1944, 4704, 9600 patches
CORNELL_LARGE = [28, 46, 65]            # 18816 (stays under the 2 GiB matrix budget; N = 29 is at its edge), 50784, 101400
ENGINE_SMALL = [1000, 2000, 5000, 10000]  # patch counts wanted from parts of the engine
ENGINE_LARGE = [20000, "full"]          # "full": the whole engine at N = 1 (88.5k patches)


def loadavg():
    return float(open("/proc/loadavg").read().split()[0])


def log(*a):
    print(*a, file=sys.stderr, flush=True)


class Runner:
    def __init__(self, binary, threads, tmp):
        self.binary, self.threads, self.tmp = binary, threads, tmp
        self.spent = 0.0   # wall seconds of all bakes run so far

    def bake(self, scene_file, extra, tag):
        report, timing = self.tmp / f"{tag}.json", self.tmp / f"{tag}.time"
        before = loadavg()
        start = time.time()
        cmd = ["/usr/bin/time", "-v", "-o", str(timing), str(self.binary), "bake", str(scene_file),
               "-o", str(self.tmp / "out.glb"), "--report", str(report), "-q", "--threads", str(self.threads)] + extra
        subprocess.run(cmd, check=True)
        wall = time.time() - start
        self.spent += wall
        tv = open(timing).read()

        def field(name):
            return float(re.search(re.escape(name) + r":\s*([0-9.]+)", tv).group(1))

        r = json.load(open(report))
        run = {"tag": tag, "patches": r["counts"]["patches"], "vertices": r["counts"]["vertices"],
               "timings": {s: r["timings"][s] for s in STAGES},
               "iterations": r["solver"]["iterations"], "entries": r["solver"]["matrixEntries"],
               "matrixFree": r["solver"]["matrixFree"],
               "user": field("User time (seconds)"), "sys": field("System time (seconds)"),
               "wall": wall, "rssMiB": field("Maximum resident set size (kbytes)") / 1024,
               "loadBefore": before, "loadAfter": loadavg(), "args": extra}
        run["cpu"] = run["user"] + run["sys"]
        return run


def fit(xs, ys):
    """log-log least squares: (slope, intercept) of log y = b log x + a."""
    x, y = np.log(np.asarray(xs, float)), np.log(np.asarray(ys, float))
    b, a = np.polyfit(x, y, 1)
    return float(b), float(a)


def evaluate(f, x):
    return math.exp(f[1] + f[0] * math.log(x))


class Scene:
    """Measured runs of one scene and predictions from them."""

    def __init__(self, name, sky):
        self.name, self.sky, self.runs = name, sky, []

    def fits(self):
        pts = [r for r in self.runs if r["patches"] >= 500 and not r["matrixFree"]]
        big = sorted(pts, key=lambda r: r["patches"])[-3:]   # memory: the base (~30 MiB) hides the slope below
        n = [r["patches"] for r in pts]
        out = {"points": len(pts),
               "solve": fit(n, [r["timings"]["solve"] for r in pts]),
               "cpu": fit(n, [r["cpu"] for r in pts]),
               "total": fit(n, [r["timings"]["total"] for r in pts]),
               "entries": fit(n, [max(r["entries"], 1) for r in pts]),
               "vertices": fit(n, [r["vertices"] for r in pts]),
               "rss": fit([r["patches"] for r in big], [r["rssMiB"] for r in big])}
        last = big[-1]
        # Peak RSS = base + bytes/entry × entries, from the largest stored run (base: the smallest run).
        base = min(r["rssMiB"] for r in self.runs)
        out["bytesPerEntry"] = (last["rssMiB"] - base) * 2**20 / max(last["entries"], 1)
        out["baseMiB"] = base
        out["iterations"] = max(r["iterations"] for r in self.runs)
        # Wall time per CPU second under the load of these runs (to turn CPU predictions into wall).
        out["wallPerCpu"] = float(np.median([r["timings"]["total"] / r["cpu"] for r in pts]))
        return out

    def predict(self, patches, nolight_rss=None):
        f = self.fits()
        entries = evaluate(f["entries"], patches)
        free = entries * BYTES_PER_ENTRY > MATRIX_BUDGET
        solve, cpu = evaluate(f["solve"], patches), evaluate(f["cpu"], patches)
        if free:
            # Matrix-free: every Jacobi iteration rebuilds every row. The fitted solve is about one
            # assembly (Cornell) or one sky-fraction pass plus one assembly (engine, --sky).
            factor = f["iterations"] if not self.sky else (1 + f["iterations"]) / 2
            solve, cpu = solve * factor, cpu * factor
            rss = nolight_rss if nolight_rss else f["baseMiB"]
        else:
            rss = f["baseMiB"] + f["bytesPerEntry"] * entries / 2**20
        return {"patches": patches, "entries": entries, "matrixFree": free, "solve": solve, "cpu": cpu,
                "rssMiB": rss,
                "rssFitMiB": evaluate(f["rss"], patches)}


def engine_subsets(runner, tmp, wanted):
    """Triangle targets for engine_subset.py giving about the wanted patch counts (bakes without light
    skip transport, so each calibration bake takes a fraction of a second)."""
    table = []
    target = 500
    while target < 60000:
        path = tmp / f"engine_{target}.glb"
        subprocess.run([sys.executable, str(HERE / "engine_subset.py"), str(ENGINE), str(path), str(target)],
                       check=True, stdout=subprocess.DEVNULL)
        r = runner.bake(path, [], f"calib_{target}")
        table.append((r["patches"], path))
        target = int(target * 1.2)
    chosen = {}
    for w in wanted:
        chosen[w] = min(table, key=lambda t: abs(math.log(t[0] / w)))[1]
    return chosen


def nolight_cornell(tmp):
    """The Cornell box without its emitter: radbake then skips transport, which times every other
    stage at sizes whose solve is out of reach."""
    g = json.load(open(CORNELL))
    for m in g["materials"]:
        m.pop("emissiveFactor", None)
        m.get("extensions", {}).pop("KHR_materials_emissive_strength", None)
    path = tmp / "cornell_nolight.gltf"
    json.dump(g, open(path, "w"))
    return path


def profile(runner, out, tmp, n):
    """perf record (software cpu-clock sampling: this KVM guest has no hardware counters) of one
    Cornell bake; else callgrind on a small one."""
    cmd = [str(runner.binary), "bake", str(CORNELL), "-o", str(tmp / "p.glb"), "--subdivide", str(n), "-q",
           "--threads", str(runner.threads)]
    text = ""
    if shutil.which("perf") and subprocess.run(["perf", "record", "-e", "cpu-clock", "-o", str(tmp / "t.data"), "true"],
                                               capture_output=True).returncode == 0:
        data = tmp / "perf.data"
        start = time.time()
        subprocess.run(["perf", "record", "-e", "cpu-clock", "-F", "499", "-o", str(data), "--"] + cmd, check=True,
                       capture_output=True)
        runner.spent += time.time() - start
        rep = subprocess.run(["perf", "report", "-i", str(data), "--stdio", "--no-children", "--sort", "dso,symbol",
                              "--percent-limit", "0.5"], capture_output=True, text=True).stdout
        text = f"perf record -e cpu-clock -F 499 (flat self time), Cornell N = {n} ({24 * n * n} patches), " \
               f"{runner.threads} threads\n\n" + rep
        tool = "perf"
    elif shutil.which("valgrind"):
        n = min(n, 6)
        cmd[cmd.index("--subdivide") + 1] = str(n)
        cg = tmp / "callgrind.out"
        subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={cg}"] + cmd, check=True,
                       capture_output=True)
        rep = subprocess.run(["callgrind_annotate", str(cg)], capture_output=True, text=True).stdout
        text = f"callgrind, Cornell N = {n}\n\n" + rep
        tool = "callgrind"
    else:
        return None
    (out / f"profile_{tool}.txt").write_text(text)
    if tool == "perf":  # the whole list, for the grouping below
        text = subprocess.run(["perf", "report", "-i", str(data), "--stdio", "--no-children", "--sort", "dso,symbol",
                               "--percent-limit", "0"], capture_output=True, text=True).stdout
    # Top entries: "  12.34%  radbake  [.] symbol"
    top = []
    for line in text.splitlines():
        m = re.match(r"\s+([0-9.]+)%\s+(\S+)\s+\[[.k]\]\s+(.*)", line)
        if m:
            top.append((float(m.group(1)), m.group(2), re.sub(r"( -)+$", "", " ".join(m.group(3).split()))))
    groups = {}
    for pct, dso, sym in top:
        g = next((name for name, rx in PROFILE_GROUPS if re.search(rx, dso + " " + sym)), "other")
        groups[g] = groups.get(g, 0) + pct
    return {"tool": tool, "n": n, "top": top[:20], "groups": sorted(groups.items(), key=lambda kv: -kv[1])}


# Profile entries grouped by what they do (first match wins; object name and symbol are searched).
PROFILE_GROUPS = [
    ("visibility rays (Embree traversal, Occlusion::visible, visibleFraction)",
     r"embree|Occlusion::|visibleFraction|rtcOccluded|filter"),
    ("kernel evaluation (form_factor: graded Gauss cells, point-polygon factor, horizon clipping)",
     r"KernelIntegrator|gaussOrder|makePolygon|nearestPoint|nearestQuadPoint|pointPolygon|vertexQuadKernel|"
     r"clip|shapeFunction|atan2|acos|asin|sqrt|__ieee754|libm\.so|pointOnPatch"),
    ("assembly bookkeeping (bilinearTransport row loop, canonicalize/sort)", r"bilinearTransport|canonicalize|sort|"
     r"__introsort|__insertion"),
    ("memory allocation / page faults", r"malloc|_int_free|free|_int_malloc|operator new|cfree|page|mm_fault|memset|"
     r"memcpy|memmove|clear_page|unmap|vma_|mmap|brk"),
    ("Jacobi iteration", r"iterate"),
    ("thread pool (oneTBB)", r"tbb"),
    ("kernel (OS) other", r"kernel\.kallsyms"),
]


def md_runs(title, runs):
    lines = [f"### {title}", "",
             "| case | patches | vertices | iter | matrix entries | free | import s | tessellate s | solve s | export s "
             "| total s | CPU s (user+sys) | CPU/wall | peak MiB | load before→after |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(runs, key=lambda r: r["patches"]):
        t = r["timings"]
        lines.append(f"| {r['tag']} | {r['patches']} | {r['vertices']} | {r['iterations']} | {r['entries']:,} | "
                     f"{'yes' if r['matrixFree'] else 'no'} | {t['import']:.3f} | {t['tessellate']:.3f} | "
                     f"{t['solve']:.2f} | {t['export']:.3f} | {t['total']:.2f} | {r['cpu']:.2f} | "
                     f"{r['cpu'] / max(r['wall'], 1e-9):.2f} | {r['rssMiB']:.0f} | {r['loadBefore']:.2f}→{r['loadAfter']:.2f} |")
    return lines


def plots(scenes, predictions, nolight, images):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    colors = {"import": "tab:gray", "tessellate": "tab:green", "solve": "tab:red", "export": "tab:blue",
              "total": "black"}
    markers = {"cornell": "o", "engine": "s"}
    fig, ax = plt.subplots(figsize=(8.5, 6))
    for sc in scenes.values():
        runs = sorted(sc.runs, key=lambda r: r["patches"])
        for s in STAGES:
            ax.plot([r["patches"] for r in runs], [max(r["timings"][s], 1e-4) for r in runs], marker=markers[sc.name],
                    color=colors[s], ls="-" if sc.name == "cornell" else "--", label=f"{sc.name} {s}")
        nl = sorted(nolight.get(sc.name, []), key=lambda r: r["patches"])
        for s in ["import", "tessellate", "export"]:
            ax.plot([r["patches"] for r in nl], [max(r["timings"][s], 1e-4) for r in nl], marker=markers[sc.name],
                    color=colors[s], ls=":", mfc="white")
        pr = [p for p in predictions if p["scene"] == sc.name and p["extrapolated"]]
        if pr:
            ax.scatter([p["patches"] for p in pr], [p["solve"] for p in pr], marker=markers[sc.name], s=90,
                       facecolors="none", edgecolors="tab:red", linewidths=1.5)
            for p in pr:
                ax.annotate(("matrix-free " if p["matrixFree"] else "") + "extrapolated", (p["patches"], p["solve"]),
                            fontsize=7, xytext=(4, -10), textcoords="offset points")
    ax.set_xscale("log"); ax.set_yscale("log")
    ax.set_xlabel("patches"); ax.set_ylabel("wall time, s")
    ax.set_title("radbake stage times (solid: Cornell, dashed: engine + sky;\n"
                 "dotted/open: bakes without light (no transport); open red: extrapolated solve)", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2, loc="upper left")
    fig.tight_layout(); fig.savefig(images / "scaling_time.png", dpi=110); plt.close(fig)

    fig, ax = plt.subplots(figsize=(8.5, 6))
    for sc in scenes.values():
        runs = sorted(sc.runs, key=lambda r: r["patches"])
        ax.plot([r["patches"] for r in runs], [r["rssMiB"] for r in runs], marker=markers[sc.name], color="tab:purple",
                ls="-" if sc.name == "cornell" else "--", label=f"{sc.name}: peak RSS")
        ax.plot([r["patches"] for r in runs], [max(r["entries"], 1) * BYTES_PER_ENTRY / 2**20 for r in runs],
                marker=markers[sc.name], color="tab:orange", ls="-" if sc.name == "cornell" else "--",
                label=f"{sc.name}: stored matrix (12 B/entry)")
        nl = sorted(nolight.get(sc.name, []), key=lambda r: r["patches"])
        ax.plot([r["patches"] for r in nl], [r["rssMiB"] for r in nl], marker=markers[sc.name], color="tab:gray",
                ls=":", mfc="white", label=f"{sc.name}: peak RSS without light (no transport)")
        pr = [p for p in predictions if p["scene"] == sc.name and p["extrapolated"]]
        if pr:
            ax.scatter([p["patches"] for p in pr], [p["rssMiB"] for p in pr], marker=markers[sc.name], s=90,
                       facecolors="none", edgecolors="tab:purple", linewidths=1.5,
                       label=f"{sc.name}: extrapolated peak RSS")
    ax.axhline(MATRIX_BUDGET / 2**20, color="k", lw=0.8, ls="-.")
    ax.annotate("2 GiB matrix budget: beyond it rows are rebuilt every iteration", (1000, MATRIX_BUDGET / 2**20 * 1.1),
                fontsize=7)
    ax.set_xscale("log"); ax.set_yscale("log")
    ax.set_xlabel("patches"); ax.set_ylabel("MiB")
    ax.set_title("radbake peak memory", fontsize=9)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout(); fig.savefig(images / "scaling_memory.png", dpi=110); plt.close(fig)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default=str(ROOT / "build/plugin/cli/radbake"))
    ap.add_argument("--out", default=str(HERE / "out"))
    ap.add_argument("--images", default=str(ROOT / "docs/images"))
    ap.add_argument("--threads", type=int, default=os.cpu_count())
    ap.add_argument("--case-budget", type=float, default=900, help="largest predicted wall s of one large case")
    ap.add_argument("--total-budget", type=float, default=2400, help="largest wall s of all bakes together")
    ap.add_argument("--profile-n", type=int, default=14)
    ap.add_argument("--no-profile", action="store_true")
    ap.add_argument("--quick", action="store_true", help="tiny sizes only, to test this script")
    a = ap.parse_args()
    global CORNELL_SMALL, CORNELL_LARGE, ENGINE_SMALL, ENGINE_LARGE
    if a.quick:
        CORNELL_SMALL, CORNELL_LARGE, ENGINE_SMALL, ENGINE_LARGE = [3, 4, 5, 6], [7, 65], [300, 600, 1000], [1500, "full"]
        a.profile_n = 4
    out, images = Path(a.out), Path(a.images)
    out.mkdir(parents=True, exist_ok=True); images.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix="radbake_scaling_"))
    runner = Runner(Path(a.bin), a.threads, tmp)
    began = datetime.datetime.now(datetime.timezone.utc)
    load_start = open("/proc/loadavg").read().split()[:3]
    version = subprocess.run([a.bin, "--version"], capture_output=True, text=True).stdout.strip()
    commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                            text=True).stdout.strip()
    cpu_model = next((l.split(":", 1)[1].strip() for l in open("/proc/cpuinfo") if l.startswith("model name")), "?")
    mem_gib = int(open("/proc/meminfo").readline().split()[1]) / 2**20

    scenes = {"cornell": Scene("cornell", sky=False), "engine": Scene("engine", sky=True)}
    runs_path = out / "runs.json"

    def save():
        json.dump({"scenes": {k: v.runs for k, v in scenes.items()}, "nolight": nolight, "predictions": predictions},
                  open(runs_path, "w"), indent=1)

    nolight, predictions = {"cornell": [], "engine": []}, []

    # Non-transport stages at every size, cheaply: bakes without light skip transport.
    log("== bakes without light (import/tessellate/export at full size)")
    cnl = nolight_cornell(tmp)
    for n in CORNELL_SMALL + CORNELL_LARGE:
        nolight["cornell"].append(runner.bake(cnl, ["--subdivide", str(n)], f"N={n} no light"))
    nolight["engine"].append(runner.bake(ENGINE, [], "full no light"))
    nolight["engine"].append(runner.bake(ENGINE, ["--lightmap", str(tmp / "lm.exr")], "full no light + lightmap"))

    log("== engine subsets")
    subsets = engine_subsets(runner, tmp, ENGINE_SMALL + [w for w in ENGINE_LARGE if w != "full"])

    log("== small cases")
    for n in CORNELL_SMALL:
        r = runner.bake(CORNELL, ["--subdivide", str(n)], f"N={n}")
        scenes["cornell"].runs.append(r); log(f"  cornell {r['patches']} patches: solve {r['timings']['solve']:.1f} s"); save()
    for w in ENGINE_SMALL:
        r = runner.bake(subsets[w], ["--sky", "1"], f"part ~{w}")
        scenes["engine"].runs.append(r); log(f"  engine {r['patches']} patches: solve {r['timings']['solve']:.1f} s"); save()

    # Large cases, smallest first, each predicted from every run so far.
    large = [("cornell", CORNELL, ["--subdivide", str(n)], f"N={n}", 24 * n * n) for n in CORNELL_LARGE]
    full_patches = nolight["engine"][0]["patches"]
    for w in ENGINE_LARGE:
        if w == "full":
            large.append(("engine", ENGINE, ["--sky", "1"], "full", full_patches))
        else:
            large.append(("engine", subsets[w], ["--sky", "1"], f"part ~{w}", None))
    log("== large cases")
    for name, path, extra, tag, patches in sorted(large, key=lambda c: c[4] or 0):
        sc = scenes[name]
        if patches is None:  # an engine part: its patch count from the calibration bake without light
            patches = runner.bake(path, [], f"{tag} count")["patches"]
        nl = [r for r in nolight[name] if r["patches"] == patches]
        p = sc.predict(patches, nl[0]["rssMiB"] if nl else None)
        # Wall of the whole bake: the fitted total, times the matrix-free factor if any.
        f = sc.fits()
        wall = evaluate(f["total"], patches) * (p["solve"] / evaluate(f["solve"], patches))
        p.update(scene=name, tag=tag, predictedWall=wall)
        run_it = wall <= a.case_budget and runner.spent + wall <= a.total_budget
        log(f"  {name} {tag}: {patches} patches, predicted {wall:.0f} s wall, {p['rssMiB']:.0f} MiB, "
            f"{'matrix-free' if p['matrixFree'] else 'stored'}; spent {runner.spent:.0f} s → "
            f"{'run' if run_it else 'NOT run (over budget)'}")
        if run_it:
            r = runner.bake(path, extra, tag)
            sc.runs.append(r)
            p["extrapolated"] = False
            p["measured"] = {"solve": r["timings"]["solve"], "total": r["timings"]["total"], "rssMiB": r["rssMiB"],
                             "cpu": r["cpu"], "matrixFree": r["matrixFree"]}
            log(f"    measured: solve {r['timings']['solve']:.1f} s, total {r['timings']['total']:.1f} s, "
                f"{r['rssMiB']:.0f} MiB")
        else:
            p["extrapolated"] = True
        predictions.append(p); save()

    prof = None if a.no_profile else profile(runner, out, tmp, a.profile_n)
    load_end = open("/proc/loadavg").read().split()[:3]

    # Report.
    L = ["# radbake scaling with patch count", "",
         f"- machine: {os.cpu_count()} cores ({cpu_model}), {mem_gib:.0f} GiB, {platform.platform()}",
         f"- radbake: {version} (git {commit}), {a.bin}; --threads {a.threads}",
         f"- date: {began:%Y-%m-%d %H:%M} UTC",
         f"- load average (1, 5, 15 min): {' '.join(load_start)} at start, {' '.join(load_end)} at end"
         f" (on {os.cpu_count()} cores: above {os.cpu_count()} other work competes and wall times inflate;"
         f" CPU s = user + sys is the load-independent measure)",
         f"- wall time of all bakes: {runner.spent:.0f} s; budgets: {a.case_budget:.0f} s per large case,"
         f" {a.total_budget:.0f} s in all", "",
         "Cornell box: tests/data/scenes/cornell_box.gltf, 24 input quads, --subdivide N → 24 N² patches. "
         "Engine: 2CylinderEngine.glb with --sky 1 (it has no emitter); below its full size, parts of it "
         "(bench/scaling/engine_subset.py keeps the first mesh instances). Stage times are radbake's report "
         "(wall); solve includes the BVH build, the sky-fraction pass (engine), the matrix assembly and the "
         "Jacobi iterations.", ""]
    L += md_runs("Cornell box (measured)", scenes["cornell"].runs) + [""]
    L += md_runs("2CylinderEngine + sky 1 (measured)", scenes["engine"].runs) + [""]
    L += md_runs("Bakes without light (transport skipped): the other stages at full size",
                 nolight["cornell"] + nolight["engine"]) + [""]
    L += ["### Fitted growth (log-log least squares over the stored-matrix runs with ≥ 500 patches)", "",
          "| scene | points | solve wall ∝ n^ | CPU ∝ n^ | total wall ∝ n^ | matrix entries ∝ n^ | peak RSS ∝ n^ (largest 3) "
          "| bytes per entry (peak RSS) | wall/CPU |", "|---|---|---|---|---|---|---|---|---|"]
    for sc in scenes.values():
        f = sc.fits()
        L.append(f"| {sc.name} | {f['points']} | {f['solve'][0]:.2f} | {f['cpu'][0]:.2f} | {f['total'][0]:.2f} | "
                 f"{f['entries'][0]:.2f} | {f['rss'][0]:.2f} | {f['bytesPerEntry']:.1f} | {f['wallPerCpu']:.2f} |")
    L += ["", "### Large cases: prediction, and measurement where the budget allowed", "",
          "Predictions come from the fit of the runs before each case. **extrapolated** = not run. Past the "
          "2 GiB matrix budget (entries × 12 B) the solver is matrix-free and rebuilds every row in each Jacobi "
          "iteration: predicted solve = fitted solve × iterations (Cornell) or × (1 + iterations)/2 (engine, "
          "whose fitted solve includes one sky-fraction pass), peak memory = the bake without light.", "",
          "| scene | case | patches | status | matrix entries (pred.) | matrix-free (pred.) | solve s (pred.) | "
          "CPU s (pred.) | whole bake wall s (pred.) | peak MiB (pred.) | measured solve s | measured CPU s | measured peak MiB |",
          "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for p in predictions:
        m = p.get("measured")
        L.append(f"| {p['scene']} | {p['tag']} | {p['patches']} | {'**extrapolated**' if p['extrapolated'] else 'run'} | "
                 f"{p['entries']:.3g} | {'yes' if p['matrixFree'] else 'no'} | {p['solve']:.0f} | {p['cpu']:.0f} | "
                 f"{p['predictedWall']:.0f} ({p['predictedWall'] / 3600:.2f} h) | {p['rssMiB']:.0f} | "
                 f"{m['solve'] if m else float('nan'):.1f} | {m['cpu'] if m else float('nan'):.0f} | "
                 f"{m['rssMiB'] if m else float('nan'):.0f} |")
    if prof:
        L += ["", f"### Where the time goes ({prof['tool']}, Cornell N = {prof['n']}, {24 * prof['n'] ** 2} patches)", "",
              "| self % | object | function |", "|---|---|---|"]
        for pct, dso, sym in prof["top"]:
            L.append(f"| {pct:.2f} | {dso} | `{sym[:140]}` |")
        L += ["", "Grouped:", "", "| group | self % |", "|---|---|"]
        for g, pct in prof["groups"]:
            L.append(f"| {g} | {pct:.1f} |")
        L += ["", f"Full report: bench/scaling/out/profile_{prof['tool']}.txt"]
    L += ["", "Plots: docs/images/scaling_time.png, docs/images/scaling_memory.png. Raw data: bench/scaling/out/runs.json."]
    text = "\n".join(L) + "\n"
    (out / "results.md").write_text(text)
    save()
    plots(scenes, predictions, nolight, images)
    print(text)
    shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
