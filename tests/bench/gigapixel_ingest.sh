#!/usr/bin/env bash
# Ingest of a gigapixel JPEG by `zoomwarp ingest` against `vips dzsave` on the same file, in one
# run (issue 18): wall time, CPU, peak RSS and bytes stored, as medians over interleaved rounds
# with their ratios, and the PSNR of the stored full-resolution level against the decoded source.
#
# The test image is the issue's: a 5312×2988 crop of a photograph (default the corpus's
# nuthatch_tree_trunk.jpg) replicated 6×10 by `vips replicate` into a 31872×29880 (952 MP) JPEG
# at --source-quality. Everything lives in one temp folder that the EXIT trap removes.
#
# Run `tests/bench/gigapixel_ingest.sh --help` for the options.
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)

rounds=3
across=6
down=10
source_quality=85
photo="$repo_dir/../shared/corpus/nuthatch_tree_trunk.jpg"
zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"
keep_dir=""

usage() {
  cat <<EOF
usage: tests/bench/gigapixel_ingest.sh [OPTIONS]

Builds a gigapixel JPEG from a photograph, then ingests it with zoomwarp and with vips dzsave
(its defaults: 254-px tiles, overlap 1, JPEG Q75) in interleaved rounds, and prints a Markdown
table: wall time, CPU (user+sys) and peak RSS (median and range), stored bytes against the
source's, ratios zoomwarp/vips, and the PSNR of zoomwarp's level 0 against the decoded source.
Needs vips (libvips-tools) and GNU time; measure on a quiet machine.

options:
  --photo FILE           the photograph cropped and replicated (default $photo)
  --across N, --down N   copies across and down (default $across x $down: 952 MP with the default photo)
  --source-quality Q     JPEG quality of the built source (default $source_quality)
  --rounds N             interleaved rounds of (zoomwarp, vips) (default $rounds)
  --zoomwarp PATH        zoomwarp binary (default build-release/bin/zoomwarp)
  --keep DIR             build the source in DIR and keep it (reused when present)
  -h, --help             this text
EOF
}

while (($#)); do
  case "$1" in
    --photo) photo=${2:?--photo needs a file}; shift 2 ;;
    --across) across=${2:?--across needs a count}; shift 2 ;;
    --down) down=${2:?--down needs a count}; shift 2 ;;
    --source-quality) source_quality=${2:?--source-quality needs a value}; shift 2 ;;
    --rounds) rounds=${2:?--rounds needs a count}; shift 2 ;;
    --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a path}; shift 2 ;;
    --keep) keep_dir=${2:?--keep needs a folder}; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for n in across down source_quality rounds; do
  [[ ${!n} =~ ^[1-9][0-9]*$ ]] || { echo "--${n//_/-} must be a positive integer" >&2; exit 2; }
done
for tool in vips vipsheader /usr/bin/time; do
  command -v "$tool" >/dev/null || { echo "needs $tool (apt-get install libvips-tools time)" >&2; exit 2; }
done
[[ -x $zoomwarp_bin ]] || { echo "no zoomwarp binary at $zoomwarp_bin (build it, or --zoomwarp)" >&2; exit 2; }
[[ -f $photo ]] || { echo "no photograph at $photo (--photo)" >&2; exit 2; }

work=$(mktemp -d -t gigapixel-ingest.XXXXXX)
trap 'rm -rf "$work"' EXIT
log() { echo "[$(date +%T)] $*" >&2; }

# ---- the source: the largest crop of the photo whose sides divide into the issue's 5312×2988 ----
src_dir=${keep_dir:-$work}
mkdir -p "$src_dir"
source="$src_dir/gigapixel_${across}x${down}_q$source_quality.jpg"
if [[ ! -f $source ]]; then
  pw=$(vipsheader -f width "$photo"); ph=$(vipsheader -f height "$photo")
  cw=$((pw < 5312 ? pw : 5312)); ch=$((ph < 2988 ? ph : 2988))
  log "building $source: a ${cw}x$ch centre crop of $(basename "$photo") x ${across}x$down at Q$source_quality"
  vips crop "$photo" "$work/crop.v" $(((pw - cw) / 2)) $(((ph - ch) / 2)) "$cw" "$ch"
  vips replicate "$work/crop.v" "${source}[Q=$source_quality]" "$across" "$down"
  rm -f "$work/crop.v"
fi
width=$(vipsheader -f width "$source"); height=$(vipsheader -f height "$source")
source_bytes=$(stat -c %s "$source")
log "source: ${width}x$height, $source_bytes bytes"

# ---- rounds: one measured run appends "wall cpu rss_kb bytes" to its tool's file ---------------
measure() {  # measure NAME OUT_DIR COMMAND...
  local name=$1 out=$2
  shift 2
  rm -rf "$out"
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" >"$work/$name.log" 2>&1 ||
    { cat "$work/$name.log" >&2; echo "$name failed" >&2; exit 1; }
  read -r wall user sys rss <"$work/time"
  echo "$wall $(echo "$user + $sys" | bc) $rss $(du -sb "$out" | cut -f1)" >>"$work/$name.runs"
  log "$name: wall $wall s, cpu $(echo "$user + $sys" | bc) s, peak RSS $((rss / 1024)) MB"
}
# The load average before the first round (building the source counts in it when it was just built;
# --keep a source to leave that out): load the figures below cannot show.
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
for ((r = 1; r <= rounds; r++)); do
  measure zoomwarp "$work/store" "$zoomwarp_bin" ingest "$source" --store "$work/store" --id gigapixel --quiet
  measure vips "$work/dz_files" vips dzsave "$source" "$work/dz"
  rm -rf "$work/dz_files" "$work/dz.dzi"
done
[[ -d $work/store ]] || { echo "zoomwarp left no store" >&2; exit 1; }

# ---- PSNR of the stored level 0 against the decoded source, over every pixel --------------------
# vips streams both files into their difference (a temp file of 6 bytes a pixel), and its stats
# give the sum of squares of all bands (row 0, column 3 of the stats matrix).
level0=$(readlink -f "$work/store/images/gigapixel")/level_0.tif
vips subtract "$source" "$level0" "$work/diff.v"
vips stats "$work/diff.v" "$work/stats.mat"
rm -f "$work/diff.v"
sum2=$(awk 'NR == 2 {print $4}' "$work/stats.mat")
mse=$(echo "$sum2 / ($width * $height * 3)" | bc -l)
psnr=$(echo "if ($mse == 0) 999 else 10 * l(255 ^ 2 / $mse) / l(10)" | bc -l)
quality=$(grep -o '"quality": [0-9]*' "$work/store/images/gigapixel/manifest.json" | grep -o '[0-9]*$' || echo "-")

# ---- table --------------------------------------------------------------------------------------
stat_of() {  # stat_of NAME COLUMN -> "median min max"
  cut -d' ' -f"$2" "$work/$1.runs" | sort -g | awk '{v[NR] = $1} END {print v[int((NR + 1) / 2)], v[1], v[NR]}'
}
ratio() { echo "scale=2; $1 / $2" | bc; }
read -r zw_wall zw_wall_lo zw_wall_hi < <(stat_of zoomwarp 1)
read -r vi_wall vi_wall_lo vi_wall_hi < <(stat_of vips 1)
read -r zw_cpu _ _ < <(stat_of zoomwarp 2)
read -r vi_cpu _ _ < <(stat_of vips 2)
read -r zw_rss _ zw_rss_hi < <(stat_of zoomwarp 3)
read -r vi_rss _ vi_rss_hi < <(stat_of vips 3)
read -r zw_bytes _ _ < <(stat_of zoomwarp 4)
read -r vi_bytes _ _ < <(stat_of vips 4)
cat <<EOF

Gigapixel ingest: ${width}x$height ($(((width * height + 500000) / 1000000)) MP) JPEG Q$source_quality, $((source_bytes / 1000000)) MB; $rounds interleaved rounds, $(nproc) cores, load before the rounds: $load_before

| | wall, median (range) | CPU user+sys | peak RSS, median (max) | stored |
|---|---|---|---|---|
| zoomwarp ingest | $zw_wall s ($zw_wall_lo–$zw_wall_hi) | $zw_cpu s | $((zw_rss / 1024)) MB ($((zw_rss_hi / 1024))) | $((zw_bytes / 1000000)) MB ($(ratio "$zw_bytes" "$source_bytes")× the source) |
| vips dzsave | $vi_wall s ($vi_wall_lo–$vi_wall_hi) | $vi_cpu s | $((vi_rss / 1024)) MB ($((vi_rss_hi / 1024))) | $((vi_bytes / 1000000)) MB ($(ratio "$vi_bytes" "$source_bytes")×) |
| ratio | **$(ratio "$zw_wall" "$vi_wall")×** | $(ratio "$zw_cpu" "$vi_cpu")× | **$(ratio "$zw_rss" "$vi_rss")×** | |

zoomwarp's level 0 (JPEG tiles at quality $quality) against the decoded source: PSNR $(printf %.1f "$psnr") dB.
EOF
