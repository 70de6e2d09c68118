#!/usr/bin/env bash
# Builds the installable Blender add-on: build/radbake-blender-addon.zip (holds radbake/__init__.py).
# Install it in Blender: Edit > Preferences > Add-ons > Install..., pick the zip, tick "radbake".
set -euo pipefail
cd "$(dirname "$0")/.."
mkdir -p build
rm -f build/radbake-blender-addon.zip
(cd plugin/blender && python3 - <<'PY'
import os, zipfile
with zipfile.ZipFile("../../build/radbake-blender-addon.zip", "w", zipfile.ZIP_DEFLATED) as z:
    for name in sorted(os.listdir("radbake")):
        if name.endswith(".py"):
            z.write(os.path.join("radbake", name))
PY
)
echo "scripts/blender_addon.sh: wrote build/radbake-blender-addon.zip"
