#!/usr/bin/env bash
# Convergence order of the bilinear and constant methods (dense-grid point error against a converged
# bilinear reference) on tests/data/scenes/floor_emitter_cube.gltf and tests/data/scenes/cornell_box.gltf.
# Writes bench/fig11/out/convergence.md and docs/images/convergence_{floor_emitter,cornell}.png.
# Bakes run one at a time. About 15 minutes on 2 idle cores.
# Usage: bench/fig11/convergence.sh   (RADBAKE=path/to/radbake to use another binary)
set -euo pipefail
cd "$(dirname "$0")/../.."
start=$(date +%s)
[ -x "${RADBAKE:-build/plugin/cli/radbake}" ] || { echo "build radbake first (scripts/build.sh)" >&2; exit 1; }
/usr/bin/python3 bench/fig11/convergence.py
echo "convergence.sh: total $(( $(date +%s) - start )) s"
