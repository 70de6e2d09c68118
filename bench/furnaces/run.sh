#!/usr/bin/env bash
# Closed shapes made with Blender's primitives (tests/blender/make_furnaces.py, the whole family):
# furnaces at N = 1, 2, 4 and lone convex objects under a sky, both methods, every vertex against
# its exact L. N = 4 is left out for the meshes whose all-pairs bake would take hours (UV sphere
# 64×32: 32k patches, torus and 32×16 sphere with the constant method). Writes
# bench/furnaces/out/furnaces.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
radbake=${RADBAKE:-build/plugin/cli/radbake}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python tests/blender/make_furnaces.py -- "$tmp" >/dev/null 2>&1
out=bench/furnaces/out
python3 tests/blender/check_furnaces.py "$radbake" "$tmp" --subdivide 1,2 --method bilinear,constant \
  --table "$out/n12.md" --only furnace_,sky_ | tail -1
python3 tests/blender/check_furnaces.py "$radbake" "$tmp" --subdivide 4 --method bilinear \
  --table "$out/n4_bilinear.md" --only cube,uvsphere8x4,uvsphere16x8,uvsphere32x16,icosphere,cylinder,cone,torus,sky_ | tail -1
python3 tests/blender/check_furnaces.py "$radbake" "$tmp" --subdivide 4 --method constant \
  --table "$out/n4_constant.md" --only cube,uvsphere8x4,uvsphere16x8,icosphere,cylinder,cone,sky_ | tail -1
{
  echo "# Closed shapes from Blender's primitives (bench/furnaces/run.sh)"
  echo
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%Y-%m-%d)"
  echo
  cat "$out/n12.md"
  tail -n +3 "$out/n4_bilinear.md"
  tail -n +3 "$out/n4_constant.md"
} >"$out/furnaces.md"
rm -f "$out/n12.md" "$out/n4_bilinear.md" "$out/n4_constant.md"
echo "wrote $out/furnaces.md"
