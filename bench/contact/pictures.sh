#!/usr/bin/env bash
# Before/after pictures of the Cornell box in Blender's viewport at the foot of the tall block (the
# file's vertex colours as Blender's importer shows them, Workbench flat lighting, viewport.py):
# a uniform bake (--subdivide 16) and a refined one (--subdivide 8 --refine 0.02 --max-patches
# 10000), top row by BEFORE_RADBAKE, bottom row by AFTER_RADBAKE (default: build/plugin/cli/radbake).
#
#   bench/contact/pictures.sh BEFORE_RADBAKE [AFTER_RADBAKE] [OUT.jpg]   (default docs/images/contact_viewport.jpg)
#
# Needs blender (Debian 3.4), xvfb-run (Workbench renders need a GL context) and /usr/bin/python3
# with PIL (python3-pil, which matplotlib pulls in): the sheet is written as JPEG (smooth gradients
# take 1.3 MB as PNG, 0.1 MB as JPEG at quality 92).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
[ $# -ge 1 ] || { echo "usage: $0 BEFORE_RADBAKE [AFTER_RADBAKE] [OUT.jpg]" >&2; exit 1; }
before=$(realpath "$1")
after=$(realpath "${2:-$root/build/plugin/cli/radbake}")
out=$(realpath -m "${3:-$root/docs/images/contact_viewport.jpg}")
scene=$root/tests/data/scenes/cornell_box.gltf
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
files=()
for bin in "$before" "$after"; do
  tag=$([ "$bin" = "$before" ] && echo before || echo after)
  "$bin" bake "$scene" -o "$tmp/$tag-uniform.glb" --subdivide 16 -q
  "$bin" bake "$scene" -o "$tmp/$tag-refined.glb" --subdivide 8 --refine 0.02 --max-patches 10000 -q
  files+=("$tmp/$tag-uniform.glb" "$tmp/$tag-refined.glb")
done
xvfb-run -a blender -b --factory-startup --python-exit-code 1 --python "$here/viewport.py" -- "$tmp/sheet.png" 2 "${files[@]}" 2>&1 |
  grep '^viewport:'
/usr/bin/python3 -c 'import sys; from PIL import Image; Image.open(sys.argv[1]).convert("RGB").save(sys.argv[2], quality=92)' \
  "$tmp/sheet.png" "$out"
echo "pictures: wrote $out"
