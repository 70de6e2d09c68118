#!/usr/bin/env bash
# End-to-end bake of the Cornell box at several subdivisions, both methods: time of each stage and
# counts, as a Markdown table on stdout (paste into docs/results.md). Takes about 2 minutes on 2 cores.
# Usage: bench/cornell_scaling.sh [N ...]   (default 1 2 4 8 12 16)
set -euo pipefail
cd "$(dirname "$0")/.."
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
levels=("$@"); [ ${#levels[@]} -gt 0 ] || levels=(1 2 4 8 12 16)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%Y-%m-%d)"
echo
echo "| method | N | patches | unknowns | iterations | import s | tessellate s | solve s | export s | total s | peak MiB |"
echo "|---|---|---|---|---|---|---|---|---|---|---|"
for method in bilinear constant; do
  for n in "${levels[@]}"; do
    if [ "$method" = constant ] && [ "$n" -gt 8 ]; then continue; fi  # the baseline's exact near factors are slow
    /usr/bin/time -f "%M" -o "$tmp/mem" "$bin" bake examples/cornell_box.gltf -o "$tmp/out.glb" --subdivide "$n" \
      --method "$method" --report "$tmp/r.json" -q
    python3 - "$tmp/r.json" "$method" "$n" "$(cat "$tmp/mem")" <<'PY'
import json, sys
r = json.load(open(sys.argv[1])); t = r["timings"]; c = r["counts"]
unknowns = c["vertices"] if sys.argv[2] == "bilinear" else c["patches"]
print(f"| {sys.argv[2]} | {sys.argv[3]} | {c['patches']} | {unknowns} | {r['solver']['iterations']} | "
      f"{t['import']:.3f} | {t['tessellate']:.3f} | {t['solve']:.2f} | {t['export']:.3f} | {t['total']:.2f} | {int(sys.argv[4]) // 1024} |")
PY
  done
done
