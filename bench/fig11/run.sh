#!/usr/bin/env bash
# Fig. 11 of the paper, reproduced on the paper's box (tests/data/scenes/emitter_cube.gltf): dense-grid
# point error of the bilinear (N = 1…8, 10, 12, 16) and constant (N = 1…24) methods against a converged
# bilinear reference (N = 32 and 48, Richardson), the best-match table and the log-log plot.
# Writes bench/fig11/out/fig11.md (+ fig11_errors.json) and docs/images/fig11_error_vs_patches.png.
# Bakes run one at a time. About 15 minutes on 2 idle cores (the N = 48 reference is most of it).
# Usage: bench/fig11/run.sh          (RADBAKE=path/to/radbake to use another binary)
set -euo pipefail
cd "$(dirname "$0")/../.."
start=$(date +%s)
[ -x "${RADBAKE:-build/plugin/cli/radbake}" ] || { echo "build radbake first (scripts/build.sh)" >&2; exit 1; }
/usr/bin/python3 bench/fig11/fig11.py
echo "run.sh: total $(( $(date +%s) - start )) s"
