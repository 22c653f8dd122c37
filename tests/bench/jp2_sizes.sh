#!/usr/bin/env bash
# JPEG 2000 ingest at the sizes a library has (issue 31): one 1 MP photograph, a folder of them,
# and one large scan, each as a lossless (5-3) and a lossy (9-7, 40 dB) JP2 made by opj_compress;
# `zoomwarp ingest` against `vips dzsave` on the same files, interleaved rounds, median wall time
# and peak RSS, as Markdown.
#
#   tests/bench/jp2_sizes.sh [--corpus DIR] [--large-mp N] [--rounds N] [--zoomwarp BIN]
#
# The 1 MP photographs are the corpus's images resized to about 1 MP; the folder holds all of
# them, ingested with --jobs 2 against two vips dzsave side by side (xargs -P 2). The large scan
# is the corpus's lake_hill_reflection.jpg replicated to about N megapixels (default 200),
# encoded with 1024² JPEG 2000 tiles as scanning software writes them. Needs opj_compress, vips,
# oiiotool; measure on a quiet machine.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
corpus="$repo_dir/../shared/corpus"
large_mp=200
rounds=3
zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"

while [ $# -gt 0 ]; do
  case "$1" in
    --corpus) corpus="${2:?}"; shift 2 ;;
    --large-mp) large_mp="${2:?}"; shift 2 ;;
    --rounds) rounds="${2:?}"; shift 2 ;;
    --zoomwarp) zoomwarp_bin="${2:?}"; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "jp2_sizes.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done
zoomwarp_bin=$(realpath "$zoomwarp_bin")
corpus=$(realpath "$corpus")
for tool in opj_compress vips oiiotool "$zoomwarp_bin"; do
  command -v "$tool" > /dev/null || { echo "jp2_sizes.sh: needs $tool" >&2; exit 2; }
done

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
mkdir -p small/lossless small/lossy
load_before=$(cut -d' ' -f1-3 /proc/loadavg)

# About 1 MP, aspect kept.
for f in "$corpus"/*.jpg "$corpus"/*.png; do
  name=$(basename "${f%.*}")
  read -r w h < <(oiiotool --info "$f" | sed -E 's/.* ([0-9]+) x +([0-9]+),.*/\1 \2/')
  scale=$(echo "sqrt(1000000 / ($w * $h))" | bc -l)
  oiiotool "$f" --ch R,G,B --resize "$(printf '%.0f' "$(echo "$w * $scale" | bc -l)")x0" -o "$name.tif"
  opj_compress -i "$name.tif" -o "small/lossless/$name.jp2" > /dev/null
  opj_compress -i "$name.tif" -o "small/lossy/$name.jp2" -I -q 40 > /dev/null
done
one=lake_hill_reflection

# The large scan: the photograph tiled k × k times, k from the megapixels asked for.
read -r w h < <(oiiotool --info "$corpus/$one.jpg" | sed -E 's/.* ([0-9]+) x +([0-9]+),.*/\1 \2/')
k=$(printf '%.0f' "$(echo "sqrt($large_mp * 1000000 / ($w * $h))" | bc -l)")
[ "$k" -ge 1 ] || k=1
vips replicate "$corpus/$one.jpg" large.v "$k" "$k"
vips copy large.v large.tif
rm large.v
opj_compress -i large.tif -o large-lossless.jp2 -t 1024,1024 > /dev/null
opj_compress -i large.tif -o large-lossy.jp2 -t 1024,1024 -I -q 40 > /dev/null
rm large.tif
lw=$(vipsheader -f width large-lossless.jp2)
lh=$(vipsheader -f height large-lossless.jp2)

# "seconds peakKB" of a command.
measure() { /usr/bin/time -f '%e %M' "$@" 2>&1 > /dev/null | tail -1; }
zw_one() { rm -rf store; measure "$zoomwarp_bin" ingest "$1" --store store --id img --quiet; }
vips_one() { rm -rf dz; mkdir dz; measure vips dzsave "$1" dz/img; }
zw_folder() { rm -rf store; measure "$zoomwarp_bin" ingest "$1" --store store --jobs 2 --quiet; }
vips_folder() {
  rm -rf dz; mkdir dz
  # shellcheck disable=SC2016
  measure bash -c 'ls "$1"/*.jp2 | xargs -P 2 -I{} sh -c '"'"'vips dzsave "$1" "dz/$(basename "$1" .jp2)"'"'"' _ {}' _ "$1"
}

declare -A results
cases=(one-lossless one-lossy folder-lossless folder-lossy large-lossless large-lossy)
input() {
  case "$1" in
    one-*) echo "small/${1#one-}/$one.jp2" ;;
    folder-*) echo "small/${1#folder-}" ;;
    large-*) echo "$1.jp2" ;;
  esac
}
for ((r = 0; r < rounds; r++)); do
  for c in "${cases[@]}"; do
    in=$(input "$c")
    if [ "${c%%-*}" = folder ]; then
      results[$c zw]+="$(zw_folder "$in"),"
      results[$c vips]+="$(vips_folder "$in"),"
    else
      results[$c zw]+="$(zw_one "$in"),"
      results[$c vips]+="$(vips_one "$in"),"
    fi
  done
done
# Median of field $2 (1: seconds, 2: peak KB) over the rounds.
median() { tr ',' '\n' | grep -v '^$' | awk -v f="$2" '{print $f}' | sort -g | awk '{a[NR] = $1} END {print a[int((NR + 1) / 2)]}'; }

count=$(find small/lossless -name '*.jp2' | wc -l)
echo "JPEG 2000 ingest by size: $count corpus photographs at ~1 MP, one of them ($one) alone, and"
echo "a ${lw}x$lh scan ($(( lw * lh / 1000000 )) MP, $one replicated ${k}x$k, 1024² JP2 tiles);"
echo "$(nproc) cores, load before $load_before; median of $rounds interleaved rounds."
echo
echo "| input | JP2 bytes | zoomwarp ingest s | vips dzsave s | ratio | zoomwarp peak RSS MB | vips peak RSS MB |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for c in "${cases[@]}"; do
  in=$(input "$c")
  bytes=$(du -sb "$in" | cut -f1)
  zs=$(echo "${results[$c zw]}" | median x 1)
  vs=$(echo "${results[$c vips]}" | median x 1)
  zm=$(echo "${results[$c zw]}" | median x 2)
  vm=$(echo "${results[$c vips]}" | median x 2)
  printf '| %s | %s | %s | %s | %.2f× | %d | %d |\n' "$c" "$bytes" "$zs" "$vs" "$(echo "$zs / $vs" | bc -l)" \
    "$((zm / 1024))" "$((vm / 1024))"
done
