"""Bakes every mesh of make_furnaces.py and checks its exact L at every vertex (2 in a furnace,
0.5 on a lone convex object under a sky of 1).

    python3 check_furnaces.py RADBAKE FURNACE_DIR [--subdivide 1,2,4] [--method bilinear,constant]
                              [--tolerance 1e-5] [--table OUT.md]

Exact answers: a closed shell with rho = 0.5 and L0 = 1 everywhere has L = L0 / (1 - rho) = 2
(every point's hemisphere is covered by the shell, so it gathers exactly its own radiance times
rho); a convex object sees only sky, so L = rho * sky. These do not come from radbake: they are
the conservation law and the definition of the sky. Exits 1 if any vertex is off by
more than the tolerance, and prints one line per bake (min, max, worst relative error).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import glb


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("radbake")
    ap.add_argument("furnaces")
    ap.add_argument("--subdivide", default="1,2,4")
    ap.add_argument("--method", default="bilinear,constant")
    ap.add_argument("--tolerance", type=float, default=1e-5)
    ap.add_argument("--only", default="", help="comma-separated substrings of the file names to bake")
    ap.add_argument("--table", default="")
    args = ap.parse_args()
    index = json.load(open(os.path.join(args.furnaces, "index.json")))
    rows, failed = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for entry in index:
            if args.only and not any(part in entry["file"] for part in args.only.split(",")):
                continue
            for method in args.method.split(","):
                for n in args.subdivide.split(","):
                    out = os.path.join(tmp, "out.glb")
                    cmd = [args.radbake, "bake", os.path.join(args.furnaces, entry["file"]), "-o", out,
                           "--method", method, "--subdivide", n, "--tolerance", "1e-10", "--quiet",
                           "--progress", "none"] + entry["args"]
                    start = time.monotonic()
                    run = subprocess.run(cmd, capture_output=True, text=True)
                    seconds = time.monotonic() - start
                    if run.returncode != 0:
                        print(f"FAIL {entry['file']} {method} N={n}: exit {run.returncode}: {run.stderr.strip()}")
                        failed += 1
                        continue
                    L = glb.radiance(*glb.load(out))
                    exact = entry["exact"]
                    err = max(abs(v - exact) for v in L) / exact
                    ok = err <= args.tolerance
                    failed += not ok
                    line = (f"{'ok  ' if ok else 'FAIL'} {entry['file']:34s} {method:8s} N={n}  "
                            f"L {min(L):.6f} .. {max(L):.6f}  worst {err:.2e}  {seconds:.1f} s")
                    print(line, flush=True)
                    rows.append((entry, method, n, float(min(L)), float(max(L)), err))
    if args.table:
        with open(args.table, "w") as f:
            f.write("| test | mesh | shading | sides | method | N | exact L | L min … max | worst error |\n"
                    "|---|---|---|---|---|---|---|---|---|\n")
            for e, m, n, lo, hi, err in rows:
                f.write(f"| {e['kind']} | {e['primitive']} | {e['shading']} | {e['sides']} | {m} | {n} | {e['exact']:g} | "
                        f"{lo:.6f} … {hi:.6f} | {err:.1e} |\n")
    print(f"check_furnaces: {len(rows)} bakes, {failed} failed (tolerance {args.tolerance:g})")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
