#!/usr/bin/env bash
# The 2CylinderEngine (assimp's test model, as a CAD exporter wrote it) under a sky of 1, the
# scene of issue 16's accuracy and whole-asset lines: parts of it (bench/scaling/engine_subset.py,
# the instances met first up to about TARGET triangles, `--refine off` so that both transports bake
# the same patches) with the default (hierarchical) transport and, up to EXACT_MAX patches
# (default 12000), the exact one and the vertex difference (RMS and largest, % of the mean
# radiance); then the whole engine as a user bakes it (`--sky 1`, cut and refined by default).
# A Markdown table on stdout (docs/results.md; bench/hierarchical/plot.py draws it).
#
#   bench/hierarchical/engine.sh [TARGET ...]   default 8000 20000 (9.1k and 23k triangles) and "whole"
#
# About 25 minutes on 2 cores (Intel Xeon VM), most of it the whole engine (about 18 minutes).
set -euo pipefail
cd "$(dirname "$0")/../.."
. bench/common.sh
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
engine=tests/data/assets/valid/2CylinderEngine/2CylinderEngine.glb
targets=("$@"); [ ${#targets[@]} -gt 0 ] || targets=(8000 20000 whole)
exactMax=${EXACT_MAX:-12000}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
table_start "part (triangles asked)" triangles patches "hierarchical s" MiB "near entries" "far links" "cluster rays" "pair rays" "exact s" "exact MiB" speed-up RMS largest
for target in "${targets[@]}"; do
  if [ "$target" = whole ]; then
    input=$engine options=(--sky 1)
  else
    input=$tmp/part.glb options=(--sky 1 --refine off)
    python3 bench/scaling/engine_subset.py "$engine" "$input" "$target" >/dev/null
  fi
  triangles=$("$bin" info "$input" | sed -n 's/.*instances, \([0-9]*\) triangles.*/\1/p')
  /usr/bin/time -f "%e %M" -o "$tmp/hierarchical.time" "$bin" bake "$input" -o "$tmp/hierarchical.glb" "${options[@]}" \
    --report "$tmp/hierarchical.json" -q
  patches=$(python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['counts']['patches'])" "$tmp/hierarchical.json")
  diff=""
  if [ "$target" != whole ] && [ "$patches" -le "$exactMax" ]; then
    /usr/bin/time -f "%e %M" -o "$tmp/exact.time" "$bin" bake "$input" -o "$tmp/exact.glb" "${options[@]}" \
      --transport exact -q
    diff=$(python3 bench/hierarchical/compare.py "$tmp/exact.glb" "$tmp/hierarchical.glb")
  fi
  name="part ($target)"; [ "$target" = whole ] && name="whole engine (default bake)"
  python3 bench/hierarchical/row.py "$tmp" "$diff" "$name" "$triangles"
  rm -f "$tmp"/exact.* "$tmp"/hierarchical.*
done
