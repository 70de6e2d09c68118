#!/usr/bin/env bash
# The Cornell box with the default (hierarchical) transport for N in ARGS (default 7 10 14 20 28 40
# 56 65, i.e. 1.2k to 101k patches): wall time, peak memory, near entries, far links, cluster rays,
# the (vertex, patch) pairs' rays;
# for N up to EXACT_MAX (default 20) also the exact transport and the vertex difference (RMS and
# largest, % of the mean radiance). Then the exponent of time against patches, fitted from 9k
# patches up (issue 16 asks for <= 1.2). A Markdown table on stdout (docs/results.md). The whole
# default run takes about 3.5 minutes on 2 cores, most of it N = 56 and 65 and exact N = 20.
set -euo pipefail
cd "$(dirname "$0")/../.."
. bench/common.sh
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
levels=("$@"); [ ${#levels[@]} -gt 0 ] || levels=(7 10 14 20 28 40 56 65)
exactMax=${EXACT_MAX:-20}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
table_start N patches "hierarchical s" MiB "near entries" "far links" "cluster rays" "pair rays" "exact s" "exact MiB" speed-up RMS largest
for n in "${levels[@]}"; do
  transports=(hierarchical)
  [ "$n" -le "$exactMax" ] && transports+=(exact)
  for t in "${transports[@]}"; do
    /usr/bin/time -f "%e %M" -o "$tmp/$t.time" "$bin" bake examples/cornell_box.gltf -o "$tmp/$t.glb" --subdivide "$n" \
      --transport "$t" --report "$tmp/$t.json" -q
  done
  diff=""
  [ -f "$tmp/exact.glb" ] && diff=$(python3 bench/hierarchical/compare.py "$tmp/exact.glb" "$tmp/hierarchical.glb")
  python3 bench/hierarchical/row.py "$tmp" "$diff" "$n" | tee -a "$tmp/rows"
  rm -f "$tmp"/exact.*
done
fit_growth "$tmp/rows" 2 3 9000
