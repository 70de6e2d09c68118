#!/usr/bin/env bash
# Hierarchical against exact transport on the Cornell box (bilinear), for N in ARGS (default 8 12 16
# 20): wall time, peak memory, links and the vertex difference (RMS and largest, % of the mean
# radiance). A Markdown table on stdout (docs/results.md "Hierarchical transport"). N = 20 takes
# about a minute for the exact bake on 2 idle cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
levels=("$@"); [ ${#levels[@]} -gt 0 ] || levels=(8 12 16 20)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%Y-%m-%d), load $(cut -d' ' -f1 /proc/loadavg)"
echo
echo "| N | patches | exact s | exact MiB | hierarchical s | hierarchical MiB | speed-up | near entries | far links | cluster rays | RMS | largest |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
for n in "${levels[@]}"; do
  for t in exact hierarchical; do
    /usr/bin/time -f "%e %M" -o "$tmp/$t.time" "$bin" bake examples/cornell_box.gltf -o "$tmp/$t.glb" --subdivide "$n" \
      --transport "$t" --report "$tmp/$t.json" -q
  done
  diff=$(python3 bench/hierarchical/compare.py "$tmp/exact.glb" "$tmp/hierarchical.glb")
  python3 - "$n" "$tmp" "$diff" <<'PY'
import json, sys
n, tmp, diff = sys.argv[1], sys.argv[2], sys.argv[3]
et, em = open(f"{tmp}/exact.time").read().split()
ht, hm = open(f"{tmp}/hierarchical.time").read().split()
r = json.load(open(f"{tmp}/hierarchical.json"))
s = r["solver"]
rms = diff.split("rms ")[1].split()[0]
largest = diff.split("max ")[1].split()[0]
print(f"| {n} | {r['counts']['patches']} | {float(et):.1f} | {int(em) // 1024} | {float(ht):.1f} | {int(hm) // 1024} | "
      f"{float(et) / float(ht):.1f}x | {s['matrixEntries']} | {s['farLinks']} | {s['clusterRays']} | {rms} | {largest} |")
PY
done
