#!/usr/bin/env bash
# Ingest time per source format (issue 31): one photograph made into each format zoomwarp reads
# with Debian's own encoders, then `zoomwarp ingest` of each file and `vips dzsave` of the JPEG
# and JPEG 2000 files, in interleaved rounds; a Markdown table of bytes, median wall time and its
# ratio to the same image as JPEG.
#
#   tests/bench/format_ingest.sh [--image FILE] [--rounds N] [--zoomwarp BIN]
#
# Formats: JPEG Q90 (the reference), JPEG 2000 lossless (5-3) and lossy (9-7, 40 dB), as JP2;
# HEIC and AVIF (heif-enc -q 90); BigTIFF and a 256² tiled TIFF (tiffcp), both uncompressed.
# Needs opj_compress, heif-enc, tiffcp, vips, oiiotool; measure on a quiet machine.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
image="$repo_dir/../shared/corpus/lake_hill_reflection.jpg"
rounds=3
zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"

while [ $# -gt 0 ]; do
  case "$1" in
    --image) image="${2:?}"; shift 2 ;;
    --rounds) rounds="${2:?}"; shift 2 ;;
    --zoomwarp) zoomwarp_bin="${2:?}"; shift 2 ;;
    -h|--help) sed -n '2,11p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "format_ingest.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
zoomwarp_bin=$(realpath "$zoomwarp_bin")
image=$(realpath "$image")
for tool in opj_compress heif-enc tiffcp vips oiiotool "$zoomwarp_bin"; do
  command -v "$tool" > /dev/null || { echo "format_ingest.sh: needs $tool" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
oiiotool "$image" --ch R,G,B -o source.tif
oiiotool source.tif -o source.png
oiiotool source.tif --compression jpeg:90 -o photo.jpg
opj_compress -i source.tif -o lossless.jp2 > /dev/null
opj_compress -i source.tif -o lossy.jp2 -I -q 40 > /dev/null
heif-enc -q 90 source.png -o photo.heic > /dev/null
heif-enc -A -q 90 source.png -o photo.avif > /dev/null
tiffcp -8 source.tif big.tif
tiffcp -t -w 256 -l 256 source.tif tiled.tif
files=(photo.jpg lossless.jp2 lossy.jp2 photo.heic photo.avif big.tif tiled.tif)
dzsave=(photo.jpg lossless.jp2 lossy.jp2)

seconds() { /usr/bin/time -f %e "$@" 2>&1 > /dev/null | tail -1; }
declare -A times vips_times
for ((r = 0; r < rounds; r++)); do
  for f in "${files[@]}"; do
    rm -rf store
    times[$f]+="$(seconds "$zoomwarp_bin" ingest "$f" --store store --id img --quiet) "
  done
  for f in "${dzsave[@]}"; do
    rm -rf dz
    mkdir dz
    vips_times[$f]+="$(seconds vips dzsave "$f" dz/img) "
  done
done
median() { tr ' ' '\n' | grep -v '^$' | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

read -r w h < <(oiiotool --info source.tif | sed -E 's/.* ([0-9]+) x +([0-9]+),.*/\1 \2/')
jpeg_s=$(echo "${times[photo.jpg]}" | median)
echo "$(basename "$image"), ${w}x$h; $(nproc) cores, load average $(cut -d' ' -f1-3 /proc/loadavg); median of $rounds; $("$zoomwarp_bin" --version 2>/dev/null | head -1)"
echo
echo "| source | bytes | zoomwarp ingest s | × JPEG | vips dzsave s |"
echo "|---|---:|---:|---:|---:|"
for f in "${files[@]}"; do
  s=$(echo "${times[$f]}" | median)
  v="–"
  [ -n "${vips_times[$f]:-}" ] && v=$(echo "${vips_times[$f]}" | median)
  printf '| %s | %s | %s | %.2f | %s |\n' "$f" "$(stat -c %s "$f")" "$s" "$(echo "$s / $jpeg_s" | bc -l)" "$v"
done
