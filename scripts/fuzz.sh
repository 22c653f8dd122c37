#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz) with clang and runs each for SECONDS (default 120),
# starting from the seed corpus in tests/fuzz/corpus/. Crashes are written to build-fuzz/findings/.
#   scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-120}"
cmake -S tests/fuzz -B build-fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++ >/dev/null
cmake --build build-fuzz
mkdir -p build-fuzz/findings
for target in view_query edit_body; do
  work="build-fuzz/corpus/$target"
  mkdir -p "$work"
  echo "== $target: ${seconds}s"
  "build-fuzz/${target}_fuzzer" "$work" "tests/fuzz/corpus/$target" -max_total_time="$seconds" \
    -artifact_prefix="build-fuzz/findings/${target}-" -print_final_stats=1 2>&1 | grep -E "^(#[0-9]+ +DONE|stat::number_of_executed_units|stat::peak_rss|==[0-9]+==ERROR|SUMMARY|artifact_prefix|Test unit written)" || true
done
ls build-fuzz/findings
