#!/usr/bin/env bash
# Closed shapes made with Blender's primitives (tests/blender/make_furnaces.py, the whole family):
# furnaces at N = 1, 2, 4 and lone convex objects under a sky, both methods, every vertex against
# its exact L. Bilinear at N = 1, 2 on every mesh and N = 4 on all but the 64×32 sphere (32k
# patches: hours with all-pairs transport); the constant method, whose near-patch factors are far
# slower, at N = 1 on all but the 64×32 sphere, N = 2 on the smaller meshes, N = 4 on the smallest.
# Writes bench/furnaces/out/furnaces.md (about an hour on 2 cores).
set -euo pipefail
cd "$(dirname "$0")/../.."
radbake=${RADBAKE:-build/plugin/cli/radbake}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python tests/blender/make_furnaces.py -- "$tmp" >/dev/null 2>&1
out=bench/furnaces/out
check() { python3 tests/blender/check_furnaces.py "$radbake" "$tmp" "$@" | tail -1; }
small=cube_,uvsphere8x4_,uvsphere16x8_,icosphere1_,icosphere2_,cylinder6_,cylinder32_,cone8_,cone32_,torus24x12_,sky_cube,sky_uvsphere16x8,sky_icosphere2,sky_cylinder32,sky_cone32
check --subdivide 1,2 --method bilinear --table "$out/a.md"
check --subdivide 4 --method bilinear --table "$out/b.md" --only "$small,uvsphere32x16_,sky_uvsphere32x16"
check --subdivide 1 --method constant --table "$out/c.md" --only "$small,uvsphere32x16_,sky_uvsphere32x16"
check --subdivide 2 --method constant --table "$out/d.md" --only "$small"
check --subdivide 4 --method constant --table "$out/e.md" --only cube_,uvsphere8x4_,icosphere1_,cylinder6_,cone8_
{
  echo "# Closed shapes from Blender's primitives (bench/furnaces/run.sh)"
  echo
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%Y-%m-%d)"
  echo
  cat "$out/a.md"
  for part in b c d e; do tail -n +3 "$out/$part.md"; done
} >"$out/furnaces.md"
rm -f "$out"/[a-e].md
echo "wrote $out/furnaces.md"
