#!/usr/bin/env bash
# `zoomwarp compare` over every image of a folder (default: the corpus next to the repository,
# ../shared/corpus): one output folder per image (sheet.png, metrics.json, metrics.md) and
# OUT/summary.md, every image's table one after the other, with the run's settings, then an
# overview with one row per image (jq). The table in docs/compare.md is that overview.
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
# The overview, one row per image (the table of docs/compare.md): per method but traditional zoom,
# in the order compared, the salient-region gain at z = 0 and 0.5, the salient anisotropy at z = 0
# beside the uniform stretch's, the salient rotation p95 and the worst line bend at z = 0 (issue
# 30), the folds over every cell, precompute and z = 0.5 viewport times.
overview='
def fixed(d): if . == null then "n/a" else (. * pow(10; d) | round | tostring) as $s
  | if d == 0 then $s else ("0" * ([0, d + 1 - ($s | length)] | max) + $s) as $p
    | $p[:($p | length) - d] + "." + $p[($p | length) - d:] end end;
def cell(m; z; f): (.fits // ["warp"])[0] as $fit
  | [.rows[] | select(.method == m and .zoom == z and (.fit // "warp") == $fit) | f][0];
. as $r | [$r.methods[] | select(.name != "traditional") | .name] as $ms
| (($r.width / $r.height) / ($r.screen[0] / $r.screen[1])) as $a
| "| \($r.image) | \($r.width)×\($r.height) | "
  + ([([$ms[] as $m | $r | cell($m; 0; .scale_gain) | fixed(2)] | join(" / ")),
      ([$ms[] as $m | $r | cell($m; 0.5; .scale_gain) | fixed(2)] | join(" / ")),
      ((if $a < 1 then 1 / $a else $a end) | fixed(2)) + " · "
        + ([$ms[] as $m | $r | cell($m; 0; .anisotropy_salient) | fixed(2)] | join(" / ")),
      ([$ms[] as $m | $r | cell($m; 0; .rotation_p95) | fixed(1)] | join(" / ")),
      ([$ms[] as $m | $r | cell($m; 0; .line_px) | fixed(2)] | join(" / ")),
      ([$r.rows[] | .folds // 0] | add | tostring),
      ([$ms[] as $m | $r.methods[] | select(.name == $m) | .precompute_ms | fixed(0)] | join(" / ")),
      ([$ms[] as $m | $r | cell($m; 0.5; .viewport_ms) | fixed(0)] | join(" / "))] | join(" | ")) + " |"'
# Issue 41's squash overview, one row per image: the uniform stretch, the smart crop's salient
# coverage, and per method at z = 0 the salient anisotropy p90 / p99 and coverage under the
# independent map, for each fit compared.
squash='
def fixed(d): if . == null then "n/a" else (. * pow(10; d) | round | tostring) as $s
  | if d == 0 then $s else ("0" * ([0, d + 1 - ($s | length)] | max) + $s) as $p
    | $p[:($p | length) - d] + "." + $p[($p | length) - d:] end end;
. as $r | [$r.methods[] | select(.name != "traditional" and .name != "seam") | .name] as $ms
| (($r.width / $r.height) / ($r.screen[0] / $r.screen[1])) as $a
| [$r.rows[] | select(.method == "smart crop" and .zoom == 0) | .independent_coverage][0] as $crop
| "| \($r.image) | " + ((if $a < 1 then 1 / $a else $a end) | fixed(2)) + " | " + ($crop | fixed(2)) + " | "
  + ([($r.fits // ["warp"])[] as $f
      | ([$ms[] as $m | [$r.rows[] | select(.method == $m and .zoom == 0 and .fit == $f)][0]
          | "\(.independent_p90 | fixed(2))/\(.independent_p99 | fixed(2))/\(.independent_coverage | fixed(2))"] | join(" · "))]
     | join(" | ")) + " |"'
metrics=("$out"/*/metrics.json)
if [ ${#metrics[@]} -gt 0 ]; then
  methods=$(jq -r '[.methods[] | select(.name != "traditional") | .name] | join(" / ")' "${metrics[0]}")
  {
    echo
    echo "## Overview"
    echo
    echo "Per method ($methods): gain z=0 | gain z=0.5 | salient anisotropy z=0 (the uniform stretch's · each method's) | salient rotation p95 z=0 (°) | worst line bend z=0 (px, detected and curator lines ≥ 8 px) | folds, all cells | precompute ms | viewport ms z=0.5"
    echo
    echo "| image | size | gain z=0 | gain z=0.5 | aniso. z=0: stretch · methods | rotation p95 z=0 | line px z=0 | folds | precompute ms | viewport ms z=0.5 |"
    echo "|---|---|---|---|---|---|---|---|---|---|"
    for m in "${metrics[@]}"; do jq -r "$overview" "$m"; done
    if jq -e '.rows | any(.method == "smart crop")' "${metrics[0]}" > /dev/null; then
      fits=$(jq -r '(.fits // ["warp"]) | join(" | ")' "${metrics[0]}")
      echo
      echo "## Squash (issue 41)"
      echo
      echo "At zoom 0, under the independent map (spectral residual on a 128-px thumbnail, top fifth): per method ($(jq -r '[.methods[] | select(.name != "traditional" and .name != "seam") | .name] | join(" · ")' "${metrics[0]}")) salient anisotropy p90/p99/coverage, for each fit ($fits); beside the uniform stretch and the attention smart crop's coverage."
      echo
      echo "| image | stretch | smart crop coverage | $fits |"
      echo "|---|---|---|$(jq -r '(.fits // ["warp"]) | map("---") | join("|")' "${metrics[0]}")|"
      for m in "${metrics[@]}"; do jq -r "$squash" "$m"; done
    fi
  } >> "$summary"
fi
echo "compare_corpus.sh: $summary" >&2
exit $failed
