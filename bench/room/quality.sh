#!/usr/bin/env bash
# Accuracy of the default bake of issue 16's room where a viewer looks: Blender makes the room
# (bench/room/make_room.py, Suzanne level 1, 64 segments), probes.py puts points on its floor,
# walls, ceiling (not above the lamp), lamp and objects, a reference bake (REF_OPTS, default a
# budget of 140,000 patches) and each candidate evaluate their radiance there, and quality.py
# prints a table: per kind of surface the RMS, largest and mean difference against the reference.
# Candidates: the default bake, then each argument as a set of bake options. About 8 minutes on 2
# cores (the reference about 4). The probes are evaluated at export, which takes its own time: the
# table gives the bake's time before export.
#
#   bench/room/quality.sh ["--max-patches 35000" ...]
set -euo pipefail
cd "$(dirname "$0")/../.."
. bench/common.sh
bin=${RADBAKE:-build/plugin/cli/radbake}
[ -x "$bin" ] || scripts/build.sh
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
blender -b --factory-startup --python-exit-code 1 --python bench/room/make_room.py -- "$tmp/room.glb" 1 64 \
  >"$tmp/blender.log" 2>&1 || { cat "$tmp/blender.log" >&2; exit 1; }
python3 bench/room/probes.py "$tmp/room.glb" "$tmp/probes.csv" >/dev/null
bake() {  # NAME OPTIONS...
  local name=$1; shift
  "$bin" bake "$tmp/room.glb" -o "$tmp/$name.glb" --probe "$tmp/probes.csv" --probe-out "$tmp/$name.csv" \
    --report "$tmp/$name.json" -q "$@"
}
read -r -a ref_opts <<<"${REF_OPTS:---max-patches 140000}"
bake reference "${ref_opts[@]}"
specs=()
bake default
specs+=("default=$tmp/default.csv:$tmp/default.json")
k=0
for options in "$@"; do
  k=$((k + 1))
  read -r -a opts <<<"$options"
  bake "candidate$k" "${opts[@]}"
  specs+=("${options// /_}=$tmp/candidate$k.csv:$tmp/candidate$k.json")
done
machine_line
echo "reference: ${ref_opts[*]} ($(python3 -c "import json,sys; print(json.load(open(sys.argv[1]))['counts']['patches'])" "$tmp/reference.json") patches)"
echo
python3 bench/room/quality.py "$tmp/probes.csv" "$tmp/reference.csv" "${specs[@]}"
