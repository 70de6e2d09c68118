#!/usr/bin/env bash
# Closed shapes made with Blender's primitives (tests/blender/make_furnaces.py, the whole family):
# furnaces at N = 1, 2, 4 and lone convex objects under a sky, both methods, every vertex against
# its exact L. What fits in about half an hour on 2 cores with all-pairs transport: bilinear at
# N = 1 on every mesh, N = 2 on all but the 64×32 sphere (18k unknowns × 8k patches: over 20
# minutes a bake), N = 4 on the small ones; the constant method, whose near-patch factors are far
# slower, at N = 1 on the smaller meshes and the torus, N = 2 and 4 on the smallest. Writes
# bench/furnaces/out/furnaces.md.
set -euo pipefail
cd "$(dirname "$0")/../.."
radbake=${RADBAKE:-build/plugin/cli/radbake}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python tests/blender/make_furnaces.py -- "$tmp" >/dev/null 2>&1
out=bench/furnaces/out
check() { python3 tests/blender/check_furnaces.py "$radbake" "$tmp" "$@" | tail -1; }
all_but_64=cube_,uvsphere8x4_,uvsphere16x8_,uvsphere32x16_,icosphere,cylinder,cone,torus,sky_
small=cube_,uvsphere8x4_,uvsphere16x8_,icosphere1_,cylinder6_,cone8_,sky_cube,sky_cone32
smallest=cube_,uvsphere8x4_,cone8_
check --subdivide 1 --method bilinear --table "$out/a.md"
check --subdivide 2 --method bilinear --table "$out/b.md" --only "$all_but_64"
check --subdivide 4 --method bilinear --table "$out/c.md" --only "$small,torus24x12_flat_both"
check --subdivide 1 --method constant --table "$out/d.md" --only "$small,icosphere2_,cylinder32_,cone32_,torus24x12_flat"
check --subdivide 2 --method constant --table "$out/e.md" --only "$smallest,icosphere1_,cylinder6_"
check --subdivide 4 --method constant --table "$out/f.md" --only "cube_flat,uvsphere8x4_flat,cone8_flat"
# The issue's table at N = 4 (about 15 more minutes).
check --subdivide 4 --method bilinear --table "$out/g.md" --only "furnace_torus24x12,furnace_uvsphere32x16_smooth"
check --subdivide 4 --method constant --table "$out/h.md" --only "furnace_cone8,furnace_cylinder6,furnace_icosphere1"
{
  echo "# Closed shapes from Blender's primitives (bench/furnaces/run.sh)"
  echo
  echo "machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs), $(date -u +%Y-%m-%d)"
  echo
  cat "$out/a.md"
  for part in b c d e f g h; do tail -n +3 "$out/$part.md"; done
} >"$out/furnaces.md"
rm -f "$out"/[a-h].md
echo "wrote $out/furnaces.md"
