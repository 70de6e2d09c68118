#!/usr/bin/env bash
# Fuzzes the glTF importer with libFuzzer (clang, ASan + UBSan) for SECONDS (default 600), seeded
# with every asset and scene in tests/data. Crashes land in build-fuzz/crashes/; turn each into a
# regression test in tests/ before fixing it.
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${1:-600}
command -v clang++ >/dev/null || { sudo_cmd=""; [ "$(id -u)" -eq 0 ] || sudo_cmd=sudo; $sudo_cmd apt-get install -y -qq clang >/dev/null; }
scripts/setup.sh
cmake -S . -B build-fuzz -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ \
  -DRADBAKE_FUZZ=ON -DRADBAKE_TESTS=OFF -DRADBAKE_BENCHMARKS=OFF >/dev/null
cmake --build build-fuzz --target importers_fuzz
mkdir -p build-fuzz/corpus build-fuzz/crashes
data=${RADBAKE_TEST_DATA_DIR:-tests/data}
find "$data/assets" "$data/scenes" -name '*.gl*' -size -2M -exec cp {} build-fuzz/corpus/ \;
echo "fuzzing for ${seconds}s ($(ls build-fuzz/corpus | wc -l) seeds)"
build-fuzz/tests/fuzz/importers_fuzz build-fuzz/corpus -max_total_time="$seconds" -timeout=20 -rss_limit_mb=4096 \
  -artifact_prefix=build-fuzz/crashes/ -print_final_stats=1
