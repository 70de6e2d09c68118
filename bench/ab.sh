#!/usr/bin/env bash
# Two builds of radbake on one bake, timed in alternation: A, B, A, B, ... ROUNDS times each, then
# every wall time sorted, the fastest of each and B's fastest over A's. This VM's speed drifts by
# 10-20% over minutes and hours, so runs far apart (or two builds run side by side, one thread
# each: 11% apart once, 1% on the repeat) cannot tell a 5% change; alternating runs see the same
# drift, and the fastest of a few is what the machine can do (noise only slows a run down).
# Usage: bench/ab.sh BUILD_A BUILD_B ROUNDS INPUT [bake options...]
#   e.g. bench/ab.sh /tmp/radbake-before build/plugin/cli/radbake 4 examples/cornell_box.gltf --subdivide 20
set -euo pipefail
[ $# -ge 4 ] || { sed -n '2,8p' "$0" | cut -c3-; exit 2; }
a=$(realpath "$1") b=$(realpath "$2") rounds=$3 input=$(realpath "$4")
shift 4
cd "$(dirname "$0")/.."
. bench/common.sh
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
for ((i = 0; i < rounds; ++i)); do
  for side in a b; do
    bin=$a; [ $side = b ] && bin=$b
    /usr/bin/time -f "%e" -a -o "$tmp/$side" "$bin" bake "$input" -o "$tmp/$side.glb" -q "$@"
  done
done
machine_line
for side in a b; do
  bin=$a; [ $side = b ] && bin=$b
  echo "$side ($bin): $(sort -g "$tmp/$side" | tr '\n' ' ')s"
done
python3 - "$tmp/a" "$tmp/b" <<'PY'
import sys
a, b = (min(float(x) for x in open(p)) for p in sys.argv[1:])
print(f"fastest b / fastest a: {b / a:.3f}")
PY
