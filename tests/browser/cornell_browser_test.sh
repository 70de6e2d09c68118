#!/usr/bin/env bash
# A baked glTF shows right in a real browser: bakes the Cornell box, renders it with three.js in
# headless Chromium from the file's camera (tools/render_gltf.mjs) and checks the pixels on the red
# wall, the green wall, the floor, the back wall and the light against 255·sRGB(clamp(2^EV·L)),
# L the exact radiance there from `radbake --probe` (an answer independent of exporter and viewer).
#   cornell_browser_test.sh RADBAKE_BINARY
# Two variants:
#   vertex colours: --view Standard --exposure EV (COLOR_0, KHR_materials_unlit), rendered with no
#     tone mapping; tolerance ±2 code values (measured: ≤ 0.6, from 8-bit output and SwiftShader).
#   lightmap: --lightmap (TEXCOORD_1 + MOZ_lightmap, PBR materials kept), rendered with
#     LinearToneMapping at 2^EV; tolerance ±4 code values (measured: ≤ 2.7, all darker). three.js
#     (r187) takes the dielectric specular lobe's share (F0 0.04, roughness 1) out of the diffuse
#     term that a lightmap feeds (RE_IndirectDiffuse_Physical: × (1 − FssEss − Fms·Ems)), so the
#     surfaces show 2–5 % darker than ρ·E/π, depending on the view angle; the same file with
#     KHR_materials_specular {specularFactor: 0} matches within 0.4 code values.
#   refined edges: --refine; no T-junction in the written mesh, and the pixels on the edges where a
#     fan meets split cells show the file's colour (±3 code values).
# Each check also holds the same pixels against the values of EV − 1, which must fail (a check that
# cannot tell the exposures apart proves nothing). RADBAKE_BROWSER_BAKE_EV bakes/renders with another
# EV than the one expected, to see the test fail. RADBAKE_BROWSER_KEEP=1 keeps the work folder.
# Exit 77 (ctest SKIP) when node, Chromium or tools/node_modules (three, playwright-core) are missing.
set -uo pipefail

if [ $# -ne 1 ]; then
  echo "usage: $0 RADBAKE_BINARY" >&2
  exit 2
fi
radbake=$(realpath "$1")
root=$(cd "$(dirname "$0")/../.." && pwd)
cd "$root"

chromium=${CHROMIUM:-/usr/bin/chromium}
command -v node >/dev/null 2>&1 || { echo "SKIP: node is not installed (scripts/setup.sh)"; exit 77; }
[ -x "$chromium" ] || { echo "SKIP: no Chromium at $chromium (scripts/setup.sh: apt-get install chromium)"; exit 77; }
for m in three playwright-core; do
  [ -d "tools/node_modules/$m" ] || { echo "SKIP: tools/node_modules/$m is missing (scripts/setup.sh: npm ci in tools/)"; exit 77; }
done

ev=1                                    # walls at 0.1–0.6 after exposure: mid-range code values
bake_ev=${RADBAKE_BROWSER_BAKE_EV:-$ev}
control_ev=$(node -e "console.log($ev - 1)")
subdivide=8                             # the points are vertices of the 8×8 patch grid
lightmap_size=512
tol_vertex=2
tol_lightmap=4

tmp=$(mktemp -d)
if [ "${RADBAKE_BROWSER_KEEP:-0}" = 1 ]; then echo "work folder: $tmp"; else trap 'rm -rf "$tmp"' EXIT; fi
start=$(date +%s)
status=0

run() {  # command, its output shown only when it fails
  local out rc=0
  out=$("$@" 2>&1) || rc=$?
  if [ "$rc" -ne 0 ]; then printf '%s\n' "$out"; echo "FAILED ($rc): $*"; fi
  return "$rc"
}

scene=examples/cornell_box.gltf
run node tests/browser/cornell_browser.mjs points "$scene" "$tmp" || exit 1

# The exact radiance at the points, at the bake settings of the variants.
run "$radbake" bake "$scene" -o "$tmp/probe.glb" --subdivide "$subdivide" \
  --probe "$tmp/points.csv" --probe-out "$tmp/values.csv" -q || exit 1

# Vertex colours: the exposure is in COLOR_0, so the viewer shows it as it is.
if run "$radbake" bake "$scene" -o "$tmp/vertex.glb" --subdivide "$subdivide" \
     --view Standard --exposure "$bake_ev" -q &&
   node tools/render_gltf.mjs "$tmp/vertex.glb" "$tmp/vertex.png" --points "$tmp/points.json" \
     >"$tmp/vertex.json" 2>"$tmp/vertex.err"; then
  node tests/browser/cornell_browser.mjs check --values "$tmp/values.csv" --render "$tmp/vertex.json" \
    --ev "$ev" --control-ev "$control_ev" --tolerance "$tol_vertex" --label "browser_cornell vertex colours" || status=1
else
  cat "$tmp/vertex.err" 2>/dev/null; echo "browser_cornell vertex colours: FAIL (bake or render)"; status=1
fi

# Lightmap: the file holds physical values; the viewer's exposure is 2^EV (LinearToneMapping).
if run "$radbake" bake "$scene" -o "$tmp/lightmap.glb" --subdivide "$subdivide" \
     --lightmap "$tmp/lightmap.exr" --lightmap-size "$lightmap_size" -q &&
   node tools/render_gltf.mjs "$tmp/lightmap.glb" "$tmp/lightmap.png" --points "$tmp/points.json" \
     --exposure "$bake_ev" >"$tmp/lightmap.json" 2>"$tmp/lightmap.err"; then
  node tests/browser/cornell_browser.mjs check --values "$tmp/values.csv" --render "$tmp/lightmap.json" \
    --ev "$ev" --control-ev "$control_ev" --tolerance "$tol_lightmap" --label "browser_cornell lightmap" || status=1
else
  cat "$tmp/lightmap.err" 2>/dev/null; echo "browser_cornell lightmap: FAIL (bake or render)"; status=1
fi

# Refined edges (--refine): where a cell meets one split once more, the written mesh is a fan from
# the finer side's midpoint, so it has no T-junction to crack along (cornell_browser.mjs edges
# counts them: 0, and a copy with one fan re-triangulated around its midpoint must give 1), and the
# pixels on those edges show the file's colour there (±3 code values: the points lie on triangle
# edges, in smooth light and 1 cm or more from the other meshes, whose faces would share their
# pixels; a crack would show black, and every point is at least 40 above it).
if run "$radbake" bake "$scene" -o "$tmp/refined.gltf" --subdivide 4 --refine 0.05 --max-patches 3000 \
     --view Standard --exposure "$bake_ev" -q &&
   node tests/browser/cornell_browser.mjs edges "$tmp/refined.gltf" "$tmp/edges" 3 0.01 &&
   node tools/render_gltf.mjs "$tmp/refined.gltf" "$tmp/refined.png" --points "$tmp/edges/edges.json" \
     >"$tmp/refined.json" 2>"$tmp/refined.err"; then
  node tests/browser/cornell_browser.mjs check-edges --points "$tmp/edges/edges.json" --render "$tmp/refined.json" \
    --tolerance 3 --dark 40 --min 20 --label "browser_cornell refined edges" || status=1
  if node tests/browser/cornell_browser.mjs crack "$tmp/refined.gltf" "$tmp/cracked.gltf" >/dev/null &&
     ! node tests/browser/cornell_browser.mjs edges "$tmp/cracked.gltf" "$tmp/cracked" 3 0.01 >/dev/null 2>&1; then
    echo "browser_cornell refined edges: control: a fan re-triangulated without its midpoint is found as a T-junction"
  else
    echo "browser_cornell refined edges: FAIL: the control's T-junction went unseen"; status=1
  fi
else
  cat "$tmp/refined.err" 2>/dev/null; echo "browser_cornell refined edges: FAIL (bake, edges or render)"; status=1
fi

echo "browser_cornell: $(( $(date +%s) - start )) s"
if [ "$status" -eq 0 ]; then echo "browser_cornell: ok"; else echo "browser_cornell: FAIL"; fi
exit "$status"
