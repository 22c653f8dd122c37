#!/usr/bin/env bash
# `zoomwarp compare` over every image of a folder (default: the corpus next to the repository,
# ../shared/corpus): one output folder per image (sheet.png, metrics.json, metrics.md) and
# OUT/summary.md, every image's table one after the other, with the run's settings. The table in
# docs/compare.md comes from it.
#
#   tests/bench/compare_corpus.sh [--corpus DIR] [-o OUT] [-- COMPARE OPTIONS…]
#   e.g. tests/bench/compare_corpus.sh -o /tmp/cmp -- --size 360x640 --zoom 0,0.25,0.5,1
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
corpus="$repo_dir/../shared/corpus"
out=""
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"

usage() {
  sed -n '2,8p' "$0" | sed 's/^# \{0,1\}//'
}

while [ $# -gt 0 ]; do
  case "$1" in
    --corpus) corpus="${2:?--corpus needs a folder}"; shift 2 ;;
    -o|--out) out="${2:?-o needs a folder}"; shift 2 ;;
    -h|--help) usage; exit 0 ;;
    --) shift; break ;;
    *) echo "compare_corpus.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
[ -n "$out" ] || { echo "compare_corpus.sh: -o OUT is required (--help)" >&2; exit 2; }
[ -d "$corpus" ] || { echo "compare_corpus.sh: no folder $corpus" >&2; exit 2; }
[ -x "$zoomwarp_bin" ] || { echo "compare_corpus.sh: build first (scripts/build.sh zoomwarp)" >&2; exit 2; }

mkdir -p "$out"
summary="$out/summary.md"
{
  echo "# zoomwarp compare over $(basename "$corpus")"
  echo
  echo "Options: \`${*:-(defaults)}\`; $(date -u +%Y-%m-%dT%H:%MZ) on $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg)."
} > "$summary"
shopt -s nullglob
images=("$corpus"/*.jpg "$corpus"/*.jpeg "$corpus"/*.png "$corpus"/*.tif "$corpus"/*.tiff "$corpus"/*.webp)
[ ${#images[@]} -gt 0 ] || { echo "compare_corpus.sh: no images in $corpus" >&2; exit 2; }
failed=0
for image in "${images[@]}"; do
  name=$(basename "$image")
  dir="$out/${name%.*}"
  echo "compare_corpus.sh: $name" >&2
  if "$zoomwarp_bin" compare "$image" -o "$dir" "$@" > "$dir.log" 2>&1; then
    { echo; echo "## $name"; echo; sed '/^# /d' "$dir/metrics.md"; } >> "$summary"
  else
    echo "compare_corpus.sh: $name failed, see $dir.log" >&2
    { echo; echo "## $name"; echo; echo "failed: $(tail -1 "$dir.log")"; } >> "$summary"
    failed=1
  fi
done
echo "compare_corpus.sh: $summary" >&2
exit $failed
