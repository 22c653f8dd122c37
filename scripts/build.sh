#!/usr/bin/env bash
# Configures and builds zoomwarp into build/ (binaries in build/bin/). Incremental after the first run.
# Arguments name targets to build (default: everything, tests included), e.g. `scripts/build.sh zoomwarp`.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-RelWithDebInfo}" >/dev/null
if [ "$#" -gt 0 ]; then cmake --build build --target "$@"; else cmake --build build; fi
