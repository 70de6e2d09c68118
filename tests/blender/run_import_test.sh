#!/usr/bin/env bash
# ctest wrapper: bake files with radbake and check that Blender's glTF importer shows their COLOR_0
# (tests/blender/import_colors.py). Exit 77 (ctest SKIP) when Blender is not installed.
#   run_import_test.sh RADBAKE_BINARY TEST_DATA_DIR      (TEST_DATA_DIR: tests/data)
set -euo pipefail

if ! command -v blender >/dev/null 2>&1; then
  echo "SKIP: blender not installed (scripts/setup.sh installs it)"
  exit 77
fi
if [ $# -ne 2 ]; then
  echo "usage: $0 RADBAKE_BINARY TEST_DATA_DIR" >&2
  exit 2
fi
radbake=$(realpath "$1")
data=$(realpath "$2")
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

check() {  # full Blender output on failure, the summary line on success
  local out rc=0
  out=$(blender -b --factory-startup --python-exit-code 1 \
    --python "$root/tests/blender/import_colors.py" -- "$1" 2>&1) || rc=$?
  if [ "$rc" -eq 0 ]; then grep '^blender_import_colors' <<<"$out"; else printf '%s\n' "$out"; fi
  return "$rc"
}

status=0

# The bundled example: emissive light, 8 meshes.
"$radbake" bake examples/cornell_box.gltf -o "$tmp/cornell.glb" --subdivide 4 -q
check "$tmp/cornell.glb" || status=1

# A textured asset with a node hierarchy, scaled children and one mesh placed by three nodes
# (baked per instance); it has no emitter, so a uniform sky lights it.
"$radbake" bake "$data/assets/valid/TextureTransformTest/TextureTransformTest.gltf" \
  -o "$tmp/texture_transform.glb" --subdivide 4 --sky 1 -q
check "$tmp/texture_transform.glb" || status=1

# Textured box whose root node is a rotation matrix.
"$radbake" bake "$data/assets/valid/BoxTextured-glb/BoxTextured.glb" -o "$tmp/box_textured.glb" \
  --subdivide 4 --sky 1 -q
check "$tmp/box_textured.glb" || status=1

exit $status
