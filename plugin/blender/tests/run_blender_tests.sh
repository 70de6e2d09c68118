#!/usr/bin/env bash
# ctest wrapper for the add-on's Blender tests: enables the add-on from this repository in a
# throwaway user-scripts folder and runs bake_in_blender.py. Exit 77 (ctest SKIP) without Blender.
#   run_blender_tests.sh RADBAKE_BINARY
set -euo pipefail
if ! command -v blender >/dev/null 2>&1; then
  echo "SKIP: blender not installed (scripts/setup.sh installs it)"
  exit 77
fi
radbake=$(realpath "$1")
root=$(cd "$(dirname "$0")/../../.." && pwd)
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/scripts/addons"
ln -s "$root/plugin/blender/radbake" "$tmp/scripts/addons/radbake"
BLENDER_USER_SCRIPTS="$tmp/scripts" RADBAKE_TEST_TMP="$tmp" blender -b --factory-startup --python-exit-code 1 \
  --python "$root/plugin/blender/tests/bake_in_blender.py" -- "$radbake" "$root" 2>&1 |
  grep -v '^Read prefs\|^Blender quit\|^$' || true
test "${PIPESTATUS[0]}" -eq 0
