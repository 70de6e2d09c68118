#!/usr/bin/env bash
# Fuzzes with libFuzzer (clang, ASan + UBSan) for SECONDS (default 600) per target. TARGETS (default
# all): importers (glTF/GLB bytes through import and tessellation, seeded with every asset and
# scene in tests/data and the hostile catalogue), bpt (.bpt text through import and tessellation,
# seeded with the teapot) and options (command lines, NUL-separated arguments). Crashes land in
# build-fuzz/crashes/; turn each into a regression test in tests/ before fixing it.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
shift || true
targets=${*:-importers bpt options}
command -v clang++ >/dev/null || { sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd=sudo; $sudo_cmd apt-get install -y -qq clang >/dev/null; }
scripts/setup.sh
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DRADBAKE_FUZZ=ON -DRADBAKE_TESTS=OFF -DRADBAKE_BENCHMARKS=OFF >/dev/null
cmake --build build-fuzz --target $(for t in $targets; do printf '%s_fuzz ' "$t"; done)
mkdir -p build-fuzz/crashes
data=${RADBAKE_TEST_DATA_DIR:-tests/data}
for target in $targets; do
  corpus=build-fuzz/corpus-$target
  mkdir -p "$corpus"
  case $target in
    importers)
      find "$data/assets" "$data/scenes" "$data/fuzz" -name '*.gl*' -size -2M -exec cp {} "$corpus/" \;
      if [ -d build/hostile ]; then find build/hostile -name '*.gl*' -size -2M -exec cp {} "$corpus/" \; 2>/dev/null || true; fi ;;
    bpt) cp "$data/scenes/teapot.bpt" "$corpus/"; printf '1\n1 1\n0 0 0\n1 0 0\n0 1 0\n1 1 1\n' >"$corpus/bilinear.bpt" ;;
    options)
      printf 'bake\0in.gltf\0-o\0out.glb\0--exposure\0nan' >"$corpus/exposure"
      printf 'bake\0in.gltf\0-o\0out.glb\0--max-memory\0512M\0--tolerance\01e-9\0--sky\01,2,3' >"$corpus/many" ;;
  esac
  echo "fuzzing $target for ${seconds}s ($(ls "$corpus" | wc -l) seeds)"
  # A teapot-sized .bpt tessellates in 0.5 s in a release build and 3.6 s under the sanitizers;
  # on a loaded 2-core machine that came near 20 s.
  timeout=20; [ "$target" = bpt ] && timeout=60
  build-fuzz/tests/fuzz/${target}_fuzz "$corpus" -max_total_time="$seconds" -timeout=$timeout -rss_limit_mb=4096 \
    -artifact_prefix=build-fuzz/crashes/$target- -print_final_stats=1
done
