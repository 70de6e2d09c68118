#!/usr/bin/env bash
# Scaling of radbake with patch count: Cornell box (--subdivide N, ~1k to ~100k patches) and the
# 2CylinderEngine (parts of it, then all of its 88.5k patches, --sky 1). Wall time per stage, CPU
# time, peak RSS and load for every bake; small sizes first, a log-log fit, and each large case run
# only when its predicted wall time fits the budgets (else its prediction is reported as
# extrapolated); a perf (or callgrind) profile of one mid-size solve; tables in
# bench/scaling/out/results.md (also printed) and plots in docs/images/scaling_{time,memory}.png.
#
# Usage: bench/scaling/run.sh [--case-budget S] [--total-budget S] [--threads T] [--no-profile] [--quick]
#   defaults: 900 s per large case, 2400 s for all bakes, all cores. Run it on an idle machine for
#   clean numbers (the load average is recorded at the start, at the end and around every bake).
set -euo pipefail
cd "$(dirname "$0")/../.."
start=$(date +%s)
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
echo "load before: $(cut -d' ' -f1-3 /proc/loadavg)" >&2
/usr/bin/python3 bench/scaling/scaling.py --bin "$bin" "$@"
echo "load after: $(cut -d' ' -f1-3 /proc/loadavg)" >&2
mkdir -p bench/scaling/out; echo "bench/scaling/run.sh took $(( $(date +%s) - start )) s" | tee bench/scaling/out/runtime.txt
