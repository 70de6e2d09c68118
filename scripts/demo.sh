#!/usr/bin/env bash
# The README's first command: build radbake, bake the bundled Cornell box into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh
mkdir -p out
# The defaults: refinement to 2% within the starting patches plus 20,000 (about 20 s on 2 cores).
build/plugin/cli/radbake bake examples/cornell_box.gltf -o out/cornell_box.glb --report out/cornell_box.json
cat <<MSG

Baked: $(pwd)/out/cornell_box.glb   (summary: out/cornell_box.json)
Look at it: drag the .glb into https://gltf-viewer.donmccurdy.com or the Khronos sample viewer, or in
Blender: File > Import > glTF 2.0, then Viewport Shading > Attribute (COLOR_0 imports as "Col"), or use the add-on (README).
MSG
