#!/usr/bin/env bash
# The add-on in Blender's real UI under Xvfb (gui_bake.py): the modal bake keeps the UI responsive
# and reports progress, cancelling stops radbake and leaves the scene alone, and a screenshot of the
# baked Cornell box in the viewport. Exit 77 (ctest SKIP) without blender or xvfb-run.
#   run_gui_test.sh RADBAKE_BINARY [SCREENSHOT.png]   (default: docs/images/blender_cornell_viewport.png)
set -uo pipefail
for tool in blender xvfb-run; do
  if ! command -v "$tool" >/dev/null 2>&1; then
    echo "SKIP: $tool not installed (apt-get install -y blender xvfb xauth)"
    exit 77
  fi
done
if [ $# -lt 1 ]; then
  echo "usage: $0 RADBAKE_BINARY [SCREENSHOT.png]" >&2
  exit 2
fi
radbake=$(realpath "$1")
if [ ! -x "$radbake" ]; then
  echo "run_gui_test: $1 is not an executable radbake" >&2
  exit 2
fi
root=$(cd "$(dirname "$0")/../../.." && pwd)
screenshot=$(realpath -m "${2:-$root/docs/images/blender_cornell_viewport.png}")
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/scripts/addons"
ln -s "$root/plugin/blender/radbake" "$tmp/scripts/addons/radbake"
# -p: the window fills the virtual screen. --enable-event-simulate: the script can press Esc, click
# the sidebar's tab and drag its edge (Blender then ignores real input, of which Xvfb has none).
# TMPDIR: the add-on's temporary folders land here, where the test looks for leftovers.
BLENDER_USER_SCRIPTS="$tmp/scripts" TMPDIR="$tmp" xvfb-run -a -s "-screen 0 1600x1000x24" \
  timeout -k 10 900 blender --factory-startup --enable-event-simulate -p 0 0 1600 1000 \
  --python-exit-code 1 --python "$root/plugin/blender/tests/gui_bake.py" -- "$radbake" "$root" "$screenshot" 2>&1 |
  grep -v '^Read prefs\|^Blender quit\|^$\|^ALSA\|^AL lib\|| INFO: \|Draco mesh compression'
status=${PIPESTATUS[0]}
if [ "$status" -ne 0 ]; then
  echo "run_gui_test: blender exited with $status"
fi
exit "$status"
