#!/usr/bin/env bash
# The lamp room (bench/hierarchical/lamp_room.py) at --subdivide N for N in ARGS (default 8 12 16 20):
# both transports' wall time and escapedFraction (0 when the closed room's light balances), and the
# hierarchical bake's vertex difference from the exact one (RMS and largest, % of the mean radiance;
# issue 16's bounds 0.5% and 3%). A Markdown table on stdout; about 1 minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/../.."
. bench/common.sh
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
levels=("$@"); [ ${#levels[@]} -gt 0 ] || levels=(8 12 16 20)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
python3 bench/hierarchical/lamp_room.py "$tmp/lamp.gltf"
table_start N "exact s" "exact escapedFraction" "hierarchical s" "hierarchical escapedFraction" RMS largest
for n in "${levels[@]}"; do
  for t in exact hierarchical; do
    "$bin" bake "$tmp/lamp.gltf" -o "$tmp/$t.glb" --subdivide "$n" --transport "$t" --report "$tmp/$t.json" -q 2>/dev/null
  done
  diff=$(python3 bench/hierarchical/compare.py "$tmp/exact.glb" "$tmp/hierarchical.glb")
  python3 - "$n" "$tmp" "$diff" <<'PY'
import json, sys
n, tmp, diff = sys.argv[1:]
e, h = (json.load(open(f"{tmp}/{t}.json")) for t in ("exact", "hierarchical"))
rms, largest = diff.split("rms ")[1].split()[0], diff.split("max ")[1].split()[0]
print(f"| {n} | {e['timings']['total']:.1f} | {e['energy']['escapedFraction']:.4f} | {h['timings']['total']:.1f} | "
      f"{h['energy']['escapedFraction']:.4f} | {rms} | {largest} |")
PY
done
