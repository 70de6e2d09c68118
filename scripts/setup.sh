#!/usr/bin/env bash
# Installs what radbake needs to build and test, from Debian packages (apt-get) and npm (the glTF
# validator). Idempotent and quick when everything is present. Run as root or with sudo available.
set -euo pipefail
cd "$(dirname "$0")/.."

packages=(cmake ninja-build g++ pkg-config
  libtinygltf-dev libosd-dev libopenexr-dev libimath-dev libopencolorio-dev
  libembree-dev libtbb-dev nlohmann-json3-dev libcli11-dev libgtest-dev libgmock-dev libbenchmark-dev libstb-dev libdraco-dev libmeshoptimizer-dev
  blender python3-numpy xvfb xauth)
packages+=(chromium)  # the browser render test (tests/browser): three.js in headless Chromium
command -v node >/dev/null 2>&1 || packages+=(nodejs)
command -v npm >/dev/null 2>&1 || packages+=(npm)

missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "setup: installing ${missing[*]}"
  sudo_cmd=""
  [ "$(id -u)" -eq 0 ] || sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

# JavaScript test tools, pinned by tools/package-lock.json (gltfpack makes the meshopt test input).
if [ ! -d tools/node_modules/gltf-validator ] || [ ! -d tools/node_modules/three ] ||
   [ ! -d tools/node_modules/playwright-core ] || [ ! -d tools/node_modules/gltfpack ]; then
  echo "setup: installing the JavaScript test tools (npm: gltf-validator, three, playwright-core, gltfpack)"
  (cd tools && npm ci --no-audit --no-fund --loglevel=error)
fi
