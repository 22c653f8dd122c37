#!/usr/bin/env bash
# Large JPEG 2000 masters in bounded memory (issue 42): a corpus photograph upscaled to each size
# asked for and saved by `vips jp2ksave` (lossy, 512² tiles: the tiled master a library keeps),
# and one saved by `opj_compress` without tiles (one tile for the whole image, OpenJPEG issue
# #1167's case); `zoomwarp ingest` against `vips dzsave` on the same files, interleaved rounds,
# median wall time and peak RSS, as Markdown.
#
#   tests/bench/jp2_masters.sh [--image FILE] [--tiled-mp "200 1000"] [--untiled-mp N]
#                              [--rounds N] [--zoomwarp BIN]
#
# Needs vips, opj_compress, /usr/bin/time; the 1000 MP file takes ~2 min to make and ~20 GB of
# /tmp for vips' intermediate. Measure on a quiet machine.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
image="$repo_dir/../shared/corpus/lake_hill_reflection.jpg"
tiled_mp="200 1000"
untiled_mp=100
rounds=2
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"

while [ $# -gt 0 ]; do
  case "$1" in
    --image) image="${2:?}"; shift 2 ;;
    --tiled-mp) tiled_mp="${2:?}"; shift 2 ;;
    --untiled-mp) untiled_mp="${2:?}"; shift 2 ;;
    --rounds) rounds="${2:?}"; shift 2 ;;
    --zoomwarp) zoomwarp_bin="${2:?}"; shift 2 ;;
    -h|--help) sed -n '2,12p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "jp2_masters.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
zoomwarp_bin=$(realpath "$zoomwarp_bin")
image=$(realpath "$image")
for tool in vips vipsheader opj_compress /usr/bin/time "$zoomwarp_bin"; do
  command -v "$tool" > /dev/null || { echo "jp2_masters.sh: needs $tool" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
w=$(vipsheader -f width "$image")
h=$(vipsheader -f height "$image")
scale_for() { echo "sqrt($1 * 1000000 / ($w * $h))" | bc -l; }

files=()
for mp in $tiled_mp; do
  echo "making a ${mp} MP tiled JP2 (vips jp2ksave)…" >&2
  vips resize "$image" up.v "$(scale_for "$mp")"
  vips jp2ksave up.v "tiled-$mp.jp2"
  rm up.v
  files+=("tiled-$mp.jp2")
done
if [ "$untiled_mp" -gt 0 ]; then
  echo "making a ${untiled_mp} MP untiled JP2 (opj_compress, lossy)…" >&2
  vips resize "$image" up.tif "$(scale_for "$untiled_mp")"
  opj_compress -i up.tif -o "untiled-$untiled_mp.jp2" -I -q 40 > /dev/null
  rm up.tif
  files+=("untiled-$untiled_mp.jp2")
fi

# "seconds peakKB" of a command.
measure() { /usr/bin/time -f '%e %M' "$@" 2>&1 > /dev/null | tail -1; }
declare -A results
for ((r = 0; r < rounds; r++)); do
  for f in "${files[@]}"; do
    rm -rf store dz && mkdir dz
    results[$f zw]+="$(measure "$zoomwarp_bin" ingest "$f" --store store --id img --quiet --max-pixels 4000000000),"
    results[$f vips]+="$(measure vips dzsave "$f" dz/img),"
  done
done
rm -rf store dz
median() { tr ',' '\n' | grep -v '^$' | awk -v f="$2" '{print $f}' | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

echo "JPEG 2000 masters from $(basename "$image") upscaled; $(nproc) cores, load before $load_before;"
echo "median of $rounds interleaved rounds; $("$zoomwarp_bin" --version 2>/dev/null | head -1)."
echo
echo "| file | pixels | JP2 bytes | zoomwarp s | vips dzsave s | time ratio | zoomwarp peak RSS MB | vips peak RSS MB | RSS ratio |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|"
for f in "${files[@]}"; do
  zs=$(echo "${results[$f zw]}" | median x 1)
  vs=$(echo "${results[$f vips]}" | median x 1)
  zm=$(echo "${results[$f zw]}" | median x 2)
  vm=$(echo "${results[$f vips]}" | median x 2)
  printf '| %s | %sx%s | %s | %s | %s | %.2f× | %d | %d | %.2f× |\n' "$f" "$(vipsheader -f width "$f")" \
    "$(vipsheader -f height "$f")" "$(stat -c %s "$f")" "$zs" "$vs" "$(echo "$zs / $vs" | bc -l)" \
    "$((zm / 1024))" "$((vm / 1024))" "$(echo "$zm / $vm" | bc -l)"
done
