#!/usr/bin/env bash
# Configures and builds zoomwarp into build/ (binaries in build/bin/). Incremental after the first run.
# Arguments name targets to build (default: everything, tests included), e.g. `scripts/build.sh zoomwarp`.
# CMAKE_BUILD_TYPE (default RelWithDebInfo) and BUILD_DIR (default build) choose another build, e.g.
# the container's: `CMAKE_BUILD_TYPE=Release BUILD_DIR=build-release scripts/build.sh zoomwarp`.
set -euo pipefail
cd "$(dirname "$0")/.."
# ccache, where installed, makes rebuilds in other checkouts of the tree cheap (CCACHE_BASEDIR
# keeps its keys independent of where the checkout lives).
launcher=()
if command -v ccache >/dev/null; then
  export CCACHE_BASEDIR="${CCACHE_BASEDIR:-$PWD}"
  launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
fi
build_dir="${BUILD_DIR:-build}"
cmake -S . -B "$build_dir" -G Ninja -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-RelWithDebInfo}" "${launcher[@]}" >/dev/null
if [ "$#" -gt 0 ]; then cmake --build "$build_dir" --target "$@"; else cmake --build "$build_dir"; fi
