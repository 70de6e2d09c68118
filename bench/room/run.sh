#!/usr/bin/env bash
# Issue 16's Blender room at growing sizes, up to about a million triangles: bench/room/make_room.py
# builds each room with Blender (Suzanne subdivision LEVEL, sphere SEGMENTS; the first size is the
# issue's room, 15.8k triangles), then radbake bakes it with the default (hierarchical) transport.
# Prints a Markdown table (triangles, patches, unknowns, wall time, peak memory, near entries, far
# links, cluster rays, the (vertex, patch) pairs' rays) and the exponent of time against patches and
# against unknowns (the receivers: a flat-shaded vertex is one per face around it, so the curved
# objects hold about four per patch and the walls one; their share grows with the level). A size whose bake passes CASE_LIMIT
# seconds (default 1800) is stopped and reported as such; the larger sizes are then skipped.
#
#   bench/room/run.sh [LEVEL:SEGMENTS[:SHADING] ...]   default 1:64 2:128 3:256 4:512 (16k, 64k, 256k, 1.03M triangles)
#
# SHADING flat (default, Blender's for its primitives) or smooth (make_room.py).
set -euo pipefail
cd "$(dirname "$0")/../.."
. bench/common.sh
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
sizes=("$@"); [ ${#sizes[@]} -gt 0 ] || sizes=(1:64 2:128 3:256 4:512)
limit=${CASE_LIMIT:-1800}
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
table_start "Suzanne level, sphere segments, shading" triangles patches unknowns "wall s" "peak MiB" "near entries" "far links" "cluster rays" "pair rays"
for size in "${sizes[@]}"; do
  IFS=: read -r level segments shading <<<"$size"
  shading=${shading:-flat}
  blender -b --factory-startup --python-exit-code 1 --python bench/room/make_room.py -- "$tmp/room.glb" "$level" "$segments" "$shading" \
    >"$tmp/blender.log" 2>&1 || { cat "$tmp/blender.log" >&2; exit 1; }
  triangles=$("$bin" info "$tmp/room.glb" | sed -n 's/.*instances, \([0-9]*\) triangles.*/\1/p')
  if ! /usr/bin/time -f "%e %M" -o "$tmp/time" timeout "$limit" "$bin" bake "$tmp/room.glb" -o "$tmp/out.glb" \
      --report "$tmp/report.json" -q; then
    echo "| $level, $segments, $shading | $triangles | – | – | not finished in $limit s | – | – | – | – | – |"
    break
  fi
  python3 - "$level" "$segments" "$shading" "$triangles" "$tmp" <<'PY' | tee -a "$tmp/rows"
import json, sys
level, segments, shading, triangles, tmp = sys.argv[1:]
wall, kib = open(f"{tmp}/time").read().split()
r = json.load(open(f"{tmp}/report.json"))
s = r["solver"]
print(f"| {level}, {segments}, {shading} | {triangles} | {r['counts']['patches']} | {r['counts']['vertices']} | {float(wall):.1f} | {int(kib) // 1024} | "
      f"{s['matrixEntries']} | {s['farLinks']} | {s['clusterRays']} | {s['nearRays']} |")
PY
done
fit_growth "$tmp/rows" 3 5 0 patches
fit_growth "$tmp/rows" 4 5 0 unknowns
