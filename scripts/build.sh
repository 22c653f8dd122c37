#!/usr/bin/env bash
# Configures and builds zoomwarp into build/ (binaries in build/bin/). Incremental after the first run.
set -euo pipefail
cd "$(dirname "$0")/.."
cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE="${CMAKE_BUILD_TYPE:-RelWithDebInfo}" >/dev/null
cmake --build build
