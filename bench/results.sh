#!/usr/bin/env bash
# Regenerates every table and figure of docs/results.md from scratch, one part after another (run
# it on an otherwise idle machine: the timing tables measure wall time). Each part writes its
# Markdown tables under bench/*/out/ (and bench/out/) and its plots under docs/images/, and this
# script prints how long each part took. About 2 hours on 2 cores.
#   bench/results.sh [part ...]    parts: kernels cornell fig11 convergence cycles scaling furnaces
#                                  hierarchical rooms engine (default: all; rooms alone takes about 15 minutes,
#                                  engine about 25); hierarchical, rooms and engine redraw
#                                  docs/images/hierarchical_scaling.png (bench/hierarchical/plot.py)
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh >/dev/null
# Plots: matplotlib from Debian, used through the system Python (/usr/bin/python3).
if ! /usr/bin/python3 -c "import matplotlib, numpy, scipy" 2>/dev/null; then
  sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get install -y -qq python3-matplotlib python3-numpy python3-scipy >/dev/null
fi
parts=("$@"); [ ${#parts[@]} -gt 0 ] || parts=(kernels cornell fig11 convergence cycles scaling furnaces hierarchical rooms engine)
mkdir -p bench/out
echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), load $(cut -d' ' -f1-3 /proc/loadavg), $(date -u +%Y-%m-%dT%H:%MZ)"
for part in "${parts[@]}"; do
  start=$(date +%s)
  case "$part" in
    kernels) build/bench/kernels_bench --benchmark_min_time=0.5 >bench/out/kernels.txt ;;
    cornell) bench/cornell_scaling.sh >bench/out/cornell_scaling.md ;;
    fig11) bench/fig11/run.sh >/dev/null ;;
    convergence) bench/fig11/convergence.sh >/dev/null ;;
    cycles) bench/cycles/run.sh >/dev/null ;;
    scaling) bench/scaling/run.sh >/dev/null ;;
    furnaces) bench/furnaces/run.sh >/dev/null ;;
    hierarchical) mkdir -p bench/hierarchical/out && bench/hierarchical/run.sh >bench/hierarchical/out/cornell.md
      /usr/bin/python3 bench/hierarchical/plot.py ;;
    rooms) mkdir -p bench/room/out && bench/room/run.sh 1:64 2:128 >bench/room/out/rooms.md
      /usr/bin/python3 bench/hierarchical/plot.py ;;
    engine) mkdir -p bench/hierarchical/out && bench/hierarchical/engine.sh >bench/hierarchical/out/engine.md
      /usr/bin/python3 bench/hierarchical/plot.py ;;
    *) echo "bench/results.sh: unknown part $part" >&2; exit 1 ;;
  esac
  echo "$part: $(( $(date +%s) - start )) s"
done
