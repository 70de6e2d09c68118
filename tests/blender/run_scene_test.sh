#!/usr/bin/env bash
# A Blender room (tests/blender/make_scene.py: lights, linked duplicates, applied modifiers, two UV
# maps, Blender's double-sided default) exported by Blender's glTF exporter bakes, keeps what it
# must, and validates. Skipped (77) without Blender.
#   run_scene_test.sh RADBAKE_BINARY TOOLS_DIR
set -euo pipefail
radbake=$1
tools=$2
here=$(cd "$(dirname "$0")" && pwd)
command -v blender >/dev/null || { echo "blender not installed: skipped"; exit 77; }
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python "$here/make_scene.py" -- "$tmp/room.glb" >"$tmp/blender.log" 2>&1 ||
  { cat "$tmp/blender.log"; exit 1; }
"$radbake" bake "$tmp/room.glb" -o "$tmp/baked.glb" --report "$tmp/report.json" --quiet --progress none
PYTHONPATH="$here" python3 - "$tmp/room.glb" "$tmp/baked.glb" "$tmp/report.json" <<'PY'
import json, sys
from glb import load, radiance

src, _ = load(sys.argv[1])
doc, binary = load(sys.argv[2])
report = json.load(open(sys.argv[3]))
failures = []
def check(ok, what):
    print(("ok   " if ok else "FAIL ") + what)
    if not ok:
        failures.append(what)

check("KHR_lights_punctual" in src.get("extensionsRequired", []), "the export requires KHR_lights_punctual")
check(len(src["extensions"]["KHR_lights_punctual"]["lights"]) == 3, "the export has three lights")
check(sum(1 for n in src["nodes"] if n.get("mesh") == 1) == 3, "the crate mesh is placed by three nodes")
check(report["counts"]["clonedMeshes"] == 2, "two instances baked as appended copies")
check(all(m.get("doubleSided") for m in src["materials"]), "Blender's materials are double-sided")
suzanne = doc["meshes"][doc["nodes"][[n["name"] for n in doc["nodes"]].index("Suzanne")]["mesh"]]
check(all("TEXCOORD_1" in p["attributes"] for p in suzanne["primitives"]), "Suzanne keeps its second UV map")
values = radiance(doc, binary)
check(all(v == v and 0 <= v < 1e6 for v in values), f"{len(values) // 3} radiance values finite and non-negative")
check(sum(1 for v in values if v > 0) > 0.9 * len(values), "the room is lit nearly everywhere")
check(report["solver"]["enclosedUnknowns"] > 0, "the closed room is recognised as closed")
check(report["solver"]["tracedUnknowns"] > 0, "the inside of the open, double-sided Suzanne gathers by rays")
sys.exit(1 if failures else 0)
PY
node "$tools/validate.js" "$tmp/baked.glb"
