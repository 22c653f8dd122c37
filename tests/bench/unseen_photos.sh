#!/usr/bin/env bash
# Issue 30's bounds on photographs the tests and docs/compare.md never saw: Debian's
# plasma-workspace-wallpapers (fetched with `apt-get download`, no root; the photographs among
# them, not the renders), each made 1280 px wide as a ~1 MP photograph, then `zoomwarp compare`
# of every method at zoom 0 on both phone screens (compare_corpus.sh), and per method the worst
# salient rotation p95 and line bend against ≤ 10° and ≤ 2 px. Prints a line per miss; exits 0
# (a benchmark: it reports, the property tests assert).
#
#   tests/bench/unseen_photos.sh [-o OUT]      (OUT default /tmp/zoomwarp-unseen; ~1 min a screen)
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
out=/tmp/zoomwarp-unseen
while [ $# -gt 0 ]; do
  case "$1" in
    -o|--out) out="${2:?-o needs a folder}"; shift 2 ;;
    -h|--help) sed -n '2,9p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "unseen_photos.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
# The photographs of the package (KDE's own photo wallpapers); the other ones are renders. Not
# EveningGlow and BytheWater: they are samples/boats_lake_sunset.jpg and
# samples/planks_by_the_water.jpg, which the tests see.
photos=(Autumn ColdRipple ColorfulCups DarkestHour FallenLeaf Grey Kite OneStandsOut Path summer_1am)
mkdir -p "$out/deb" "$out/photos"
if ! ls "$out"/deb/plasma-workspace-wallpapers_*.deb > /dev/null 2>&1; then
  (cd "$out/deb" && apt-get download -q plasma-workspace-wallpapers)
fi
dpkg-deb -x "$out"/deb/plasma-workspace-wallpapers_*.deb "$out/deb/x"
for p in "${photos[@]}"; do
  vips thumbnail "$out/deb/x/usr/share/wallpapers/$p/contents/images/2560x1600.jpg" "$out/photos/$p.jpg" 1280
done
for size in 360x640 640x360; do
  "$script_dir/compare_corpus.sh" --corpus "$out/photos" -o "$out/$size" -- --methods all --size "$size" --zoom 0
done
echo "Per method, the worst at zoom 0 over ${#photos[@]} photographs × 2 screens (bounds: rotation p95 <= 10 deg, line <= 2 px):"
jq -rs '[.[] | .image as $i | (.screen | map(tostring) | join("x")) as $s | .rows[]
          | select(.method != "traditional" and .rotation_p95 != null) | . + {where: "\($i) \($s)"}]
        | group_by(.method)[]
        | (max_by(.rotation_p95)) as $r | (map(select(.line_px != null)) | max_by(.line_px)) as $l
        | "\($r.method): rotation p95 \($r.rotation_p95 * 100 | round / 100) deg (\($r.where)), line \(if $l then "\($l.line_px * 100 | round / 100) px (\($l.where))" else "none measured" end)"
          + (if $r.rotation_p95 > 10 or ($l and $l.line_px > 2) then "  MISS" else "" end)' \
  "$out"/*x*/*/metrics.json
