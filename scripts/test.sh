#!/usr/bin/env bash
# Runs the whole test suite: unit, HTTP integration (real server on loopback), and browser tests.
# Extra arguments go to ctest, e.g. `scripts/test.sh -L unit` or `scripts/test.sh -R Iiif`.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh
# -LE: two opt-in labels. container: the root-file-system test needs root and a Debian mirror, run
# it with `ctest --test-dir build -L container` (deploy/ROOTFS.md). soak: 30 minutes of load and
# faults, run it alone with `ctest --test-dir build -L soak` (tests/README.md).
ctest --test-dir build --output-on-failure --no-tests=error -j "$(nproc)" -LE 'container|soak' "$@"
