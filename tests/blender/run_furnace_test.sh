#!/usr/bin/env bash
# Blender's primitives exported by Blender's glTF exporter at its defaults, baked by radbake, each
# checked against its exact answer (tests/blender/make_furnaces.py, check_furnaces.py): furnaces
# (L = 2) flat, smooth and auto-smooth, one- and double-sided, bilinear at N = 1 and 2, constant at
# N = 1 on the small meshes (its near-patch factors are slow), both at N = 4 on the smallest; lone convex objects under a sky (L = 0.5)
# and white open trays, flat and smooth, turned off the axes (L = 1: bilinear N = 1 and 2, constant N = 2
# double-sided). The whole
# family at N = 1, 2, 4 is bench/furnaces/run.sh (too slow for every run). Skipped (77) without
# Blender.
#   run_furnace_test.sh RADBAKE_BINARY
set -euo pipefail
radbake=$1
here=$(cd "$(dirname "$0")" && pwd)
command -v blender >/dev/null || { echo "blender not installed: skipped"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python "$here/make_furnaces.py" -- "$tmp" --quick >"$tmp/blender.log" 2>&1 ||
  { cat "$tmp/blender.log"; exit 1; }
python3 "$here/check_furnaces.py" "$radbake" "$tmp" --subdivide 1,2 --method bilinear
python3 "$here/check_furnaces.py" "$radbake" "$tmp" --subdivide 1 --method constant \
  --only cube_,uvsphere8x4_,icosphere1_,cylinder6_,cone8_,torus24x12_flat_both,sky_cube,sky_cone32_flat
python3 "$here/check_furnaces.py" "$radbake" "$tmp" --subdivide 2 --method constant --only tray_cube_flat_both
python3 "$here/check_furnaces.py" "$radbake" "$tmp" --subdivide 4 --method bilinear,constant \
  --only cube_flat_one,uvsphere8x4_flat_both,cone8_smooth_one
