#!/usr/bin/env bash
# Installs every build and test dependency of zoomwarp from Debian 12 packages (and the npm
# packages of the browser tests), non-interactively. Safe to run again: it installs only what is
# missing. This is the only install step anyone, CI included, needs.
set -euo pipefail
cd "$(dirname "$0")/.."

# Build: compiler, CMake, and the libraries fixed by DESIGN.md §3.
build_pkgs=(
  build-essential cmake ninja-build pkg-config git ca-certificates
  libopenimageio-dev openimageio-tools
  libeigen3-dev libsuitesparse-dev libcgal-dev libboost-dev
  nlohmann-json3-dev libturbojpeg0-dev libpng-dev libwebp-dev
  libopencv-imgproc-dev libopencv-objdetect-dev opencv-data
  libgtest-dev libgmock-dev libbenchmark-dev
)
# Tests and benchmarks: a browser for the viewer tests, Node for driving it, nginx and wrk to
# measure against, curl for the scripts.
test_pkgs=(chromium nodejs npm nginx-light wrk curl procps)

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${build_pkgs[@]}" "${test_pkgs[@]}"; do
  # nodejs/npm may come from elsewhere (a newer Node on the PATH is fine).
  case "$p" in nodejs) command -v node >/dev/null && continue ;; npm) command -v npm >/dev/null && continue ;; esac
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: Debian packages already installed"
fi

# npm packages of the browser tests (OpenSeadragon, playwright-core driving Debian's chromium).
if [ -f tests/browser/package.json ]; then
  if [ ! -d tests/browser/node_modules ] || [ tests/browser/package-lock.json -nt tests/browser/node_modules ]; then
    (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error)
    touch tests/browser/node_modules
  fi
fi
echo "setup: done"
