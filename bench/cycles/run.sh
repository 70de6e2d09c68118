#!/usr/bin/env bash
# Cycles bake vs radbake on the Cornell box: RMS relative error at fixed surface points against time.
# Regenerates bench/cycles/out/ (results.md, results.json, raw runs) and docs/images/cycles_vs_radbake.png,
# prints the tables and how long it took (about 10 minutes on 2 cores).
#
#   bench/cycles/run.sh
#
# Settings (environment): RADBAKE_N="1 2 4 8 12 16"  RADBAKE_REFINE="1:3000 1:20024 6:4000 8:5000 8:10000 16:20000" (N:B,
#   --subdivide N --refine $REFINE_TARGET (0.02) --max-patches B: the budget, not the target, ends refinement
#   where shadow and contact lines are sharp; 1:20024 is what `radbake bake` does with no option on this file)  CYCLES_SAMPLES="4 16 64 256 1024 2048 4096" (seed 0; the reference runs use seeds 1 and 2)
#   REF_N="16 24" (radbake levels extrapolated for the reference)  REF_SAMPLES=2048 (two Cycles runs)
#   M=13 (probe grid per face)  TAU=0.0025 (radbake counts as converged where its extrapolation step is below)
# Needs: blender (Debian 3.4), /usr/bin/python3 with numpy, scipy, matplotlib; builds radbake if missing.
set -euo pipefail
t_start=$(date +%s.%N)
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
cd "$root"
bin=build/plugin/cli/radbake
[ -x "$bin" ] || scripts/build.sh
scene=${SCENE:-tests/data/scenes/cornell_box.gltf}
RADBAKE_N=${RADBAKE_N:-"1 2 4 8 12 16"}
RADBAKE_REFINE=${RADBAKE_REFINE:-"1:3000 1:20024 6:4000 8:5000 8:10000 16:20000"}
REFINE_TARGET=${REFINE_TARGET:-0.02}
CYCLES_SAMPLES=${CYCLES_SAMPLES:-"4 16 64 256 1024 2048 4096"}
REF_N=${REF_N:-"16 24"}
REF_SAMPLES=${REF_SAMPLES:-2048}
M=${M:-13}
TAU=${TAU:-0.0025}
py=/usr/bin/python3
# The analysis needs these; fail now, not after the runs (a fresh machine has only what the tests need).
$py -c "import numpy, scipy, matplotlib" 2>/dev/null ||
  { echo "bench/cycles: needs python3-numpy python3-scipy python3-matplotlib (apt-get install them)" >&2; exit 1; }
out=bench/cycles/out
rm -rf "$out"; mkdir -p "$out/radbake" "$out/cycles" docs/images
load() { cut -d' ' -f1-3 /proc/loadavg; }
echo "== Cycles vs radbake, $(date -u '+%Y-%m-%d %H:%M:%S UTC'), load average $(load)"

# machine, versions
$py - "$out/meta.json" "$REF_N" "$TAU" "$(load)" "$(nproc)" \
    "$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)" \
    "$(blender --version 2>/dev/null | head -1)" "$($bin --version 2>&1 | head -1)" \
    "$(git rev-parse --short HEAD 2>/dev/null)$(git diff --quiet HEAD -- radiosity tessellate importers exporters plugin/cli 2>/dev/null || echo '+local changes')" <<'PY'
import json, sys, datetime
o, refn, tau, load, nproc, cpu, blender, radbake, commit = sys.argv[1:]
json.dump(dict(date=datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), ref_levels=[int(x) for x in refn.split()],
               tau=float(tau), load_before=load, nproc=int(nproc), cpu=cpu, blender=blender,
               radbake=radbake.replace("radbake ", ""), radbake_build=f"commit {commit}"),
          open(o, "w"), indent=1)
PY

# probe points, and the same scene with those points as mesh vertices
$py "$here/make_probes.py" "$scene" "$out" "$M"

timed() { # timed FILE cmd... : wall, user, sys of the child into FILE
  local f=$1; shift
  /usr/bin/time -f '%e %U %S' -o "$f" "$@"
}

# radbake at each level (the reference levels too)
levels=$(printf '%s\n' $RADBAKE_N $REF_N | sort -n | uniq)
for n in $levels; do
  timed "$out/radbake/N$n.time" "$bin" bake "$scene" -o "$out/radbake/N$n.glb" --subdivide "$n" -q \
    --report "$out/radbake/N$n.json" --probe "$out/probes.csv" --probe-out "$out/radbake/N$n.csv"
  rm -f "$out/radbake/N$n.glb"
  echo "radbake N=$n: $(cut -d' ' -f1 "$out/radbake/N$n.time") s wall, $(awk '{print $2+$3}' "$out/radbake/N$n.time") s CPU, load $(load)"
done

# radbake with adaptive refinement from a uniform start, at each budget
for nb in $RADBAKE_REFINE; do
  n=${nb%%:*}; b=${nb##*:}; e="R${n}_$b"
  timed "$out/radbake/$e.time" "$bin" bake "$scene" -o "$out/radbake/$e.glb" --subdivide "$n" --refine "$REFINE_TARGET" \
    --max-patches "$b" -q --report "$out/radbake/$e.json" --probe "$out/probes.csv" --probe-out "$out/radbake/$e.csv"
  rm -f "$out/radbake/$e.glb"
  echo "radbake --subdivide $n --refine $REFINE_TARGET --max-patches $b: $(cut -d' ' -f1 "$out/radbake/$e.time") s wall, $(awk '{print $2+$3}' "$out/radbake/$e.time") s CPU, load $(load)"
done

# Cycles at each sample count (seed 0), then two reference runs with other seeds
cyc() { # cyc NAME SAMPLES SEED
  timed "$out/cycles/$1.time" blender -b --factory-startup --python-exit-code 1 --python "$here/cycles_bake.py" -- \
    "$out/grid.gltf" "$out/cycles/$1.npz" --samples "$2" --seed "$3" > "$out/cycles/$1.log" 2>&1 \
    || { tail -20 "$out/cycles/$1.log"; exit 1; }
  echo "Cycles $2 spp (seed $3): $(tail -n 3 "$out/cycles/$1.log" | grep -o '"bake_wall": [0-9.]*' | cut -d' ' -f2 | cut -c1-6) s bake call, $(cut -d' ' -f1 "$out/cycles/$1.time") s wall, $(awk '{print $2+$3}' "$out/cycles/$1.time") s CPU, load $(load)"
}
for s in $CYCLES_SAMPLES; do cyc "S$s" "$s" 0; done
cyc "ref1_S$REF_SAMPLES" "$REF_SAMPLES" 1
cyc "ref2_S$REF_SAMPLES" "$REF_SAMPLES" 2

t_end=$(date +%s.%N)
secs=$(awk -v a="$t_start" -v b="$t_end" 'BEGIN{printf "%.0f", b-a}')
$py - "$out/meta.json" "$(load)" "$secs" <<'PY'
import json, sys
m = json.load(open(sys.argv[1])); m["load_after"] = sys.argv[2]; m["script_seconds"] = int(sys.argv[3])
json.dump(m, open(sys.argv[1], "w"), indent=1)
PY
echo
$py "$here/analyze.py" "$out" docs/images/cycles_vs_radbake.png
echo
echo "== done in $secs s (runs) + analysis; results in $out/results.md, plot in docs/images/cycles_vs_radbake.png"
