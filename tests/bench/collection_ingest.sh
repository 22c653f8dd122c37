#!/usr/bin/env bash
# Ingest of photo collections by zoomwarp against `vips dzsave` in one run on the same files
# (issue 28, "Collections"): wall time, CPU, peak RSS and bytes stored for a whole set, as medians
# over interleaved rounds, with their ratios zoomwarp/vips; and the fixed costs behind them (process
# start, one tiny image).
#
# Sets (--sets):
#   A  60 photographs of about 1 MP: 1224x816 crops at fixed offsets of the corpus photographs big
#      enough for one (JPEG or PNG), spread evenly over them, saved as JPEG Q85 (alpha flattened on
#      black, metadata stripped). Deterministic: the same corpus gives the same 60 files.
#   B  every corpus photograph of 0.5 to 16 MP (MANIFEST.tsv's megapixels column), as it is.
# Contenders (--contenders), each into a fresh store or output folder, timed as a whole:
#   bulk1  one `zoomwarp ingest DIR --store S --jobs 1 --quiet`
#   bulk2  the same with --jobs 2
#   each   `zoomwarp ingest FILE --store S --quiet`, one process per file, in a bash loop
#   vips   `vips dzsave FILE OUT/NAME`, one process per file, in a bash loop (its defaults)
# A loop runs under `/usr/bin/time bash -c '...'`: its CPU is the sum over the loop's processes,
# its peak RSS the largest one's. Everything lives in one temp folder that the EXIT trap removes.
#
# Run `tests/bench/collection_ingest.sh --help` for the options.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)

rounds=3
sets="A,B"
contenders="bulk1,bulk2,each,vips"
corpus="$repo_dir/../shared/corpus"
zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"
analyses=""
keep_dir=""
out_file=""
fixed_runs=5
set_a_count=60
crop_w=1224
crop_h=816

usage() {
  cat <<EOF
usage: tests/bench/collection_ingest.sh [OPTIONS]

Ingests photo collections with zoomwarp (one bulk process with --jobs 1 and 2, and one process
per file) and with vips dzsave (one process per file; its defaults: 254-px tiles, overlap 1,
JPEG Q75) in interleaved rounds, and prints a Markdown table per set: wall time (median, range),
CPU user+sys, peak RSS of the largest process, bytes stored against the source's (zoomwarp's split
into pyramid levels and everything else), ratios zoomwarp/vips; then the fixed costs: process start
(\`zoomwarp --help\` against \`vips --version\`) and one 64x64 JPEG ingested by each (median of $fixed_runs).
Needs vips (libvips-tools), GNU time and bc; measure on a quiet machine.

Sets:
  A  $set_a_count photographs of about 1 MP: ${crop_w}x$crop_h crops of the corpus photographs, JPEG Q85
  B  the corpus photographs of 0.5 to 16 MP, as they are

options:
  --sets LIST         sets to run, comma-separated: A, B (default $sets)
  --contenders LIST   comma-separated: bulk1, bulk2 (\`zoomwarp ingest DIR --jobs 1|2\`), each (a
                      zoomwarp process per file), vips (a dzsave process per file) (default $contenders)
  --rounds N          interleaved rounds, the contenders' order rotated each round (default $rounds)
  --zoomwarp PATH     zoomwarp binary (default build-release/bin/zoomwarp)
  --analyses MODE     pass --analyses MODE to every zoomwarp ingest (default: not passed, the
                      binary's own default)
  --corpus DIR        the corpus, with MANIFEST.tsv (default ../shared/corpus from the repository)
  --keep DIR          generate set A in DIR/collection_A and keep it (reused when complete)
  --out FILE          also write the Markdown to FILE
  -h, --help          this text
EOF
}

die() { echo "collection_ingest: error: $*" >&2; exit 1; }
log() { echo "[$(date +%T)] $*" >&2; }

while (($#)); do
  case "$1" in
    --sets) sets=${2:?--sets needs a list}; shift 2 ;;
    --contenders) contenders=${2:?--contenders needs a list}; shift 2 ;;
    --rounds) rounds=${2:?--rounds needs a count}; shift 2 ;;
    --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a path}; shift 2 ;;
    --analyses) analyses=${2:?--analyses needs a mode}; shift 2 ;;
    --corpus) corpus=${2:?--corpus needs a folder}; shift 2 ;;
    --keep) keep_dir=${2:?--keep needs a folder}; shift 2 ;;
    --out) out_file=${2:?--out needs a file}; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $rounds =~ ^[1-9][0-9]*$ ]] || { echo "--rounds must be a positive integer" >&2; exit 2; }
IFS=, read -r -a set_list <<<"$sets"
IFS=, read -r -a contender_list <<<"$contenders"
((${#set_list[@]})) || { echo "--sets is empty" >&2; exit 2; }
((${#contender_list[@]})) || { echo "--contenders is empty" >&2; exit 2; }
for s in "${set_list[@]}"; do
  [[ $s == A || $s == B ]] || { echo "--sets: unknown set '$s' (A, B)" >&2; exit 2; }
done
for c in "${contender_list[@]}"; do
  [[ $c =~ ^(bulk1|bulk2|each|vips)$ ]] || { echo "--contenders: unknown contender '$c' (bulk1, bulk2, each, vips)" >&2; exit 2; }
done
[[ -z $analyses || $analyses =~ ^(none|icaz|all)$ ]] || { echo "--analyses must be none, icaz or all" >&2; exit 2; }
for tool in vips vipsheader /usr/bin/time bc; do
  command -v "$tool" >/dev/null || { echo "needs $tool (apt-get install libvips-tools time bc)" >&2; exit 2; }
done
[[ -x $zoomwarp_bin ]] || { echo "no zoomwarp binary at $zoomwarp_bin (build it, or --zoomwarp)" >&2; exit 2; }
[[ -f $corpus/MANIFEST.tsv ]] || { echo "no corpus at $corpus (MANIFEST.tsv missing; --corpus)" >&2; exit 2; }
zoomwarp_bin=$(readlink -f "$zoomwarp_bin")
has() { [[ ",$1," == *",$2,"* ]]; }

# The bulk form (`zoomwarp ingest DIR --jobs N`, issue 28) may be missing from an older binary: say
# so before anything is measured rather than time a refusal.
if has "$contenders" bulk1 || has "$contenders" bulk2; then
  "$zoomwarp_bin" ingest --help 2>&1 | grep -q -- '--jobs' ||
    die "$zoomwarp_bin has no bulk ingest (\`zoomwarp ingest DIR --jobs N\`, issue 28): build one that has it, or leave bulk1 and bulk2 out (--contenders each,vips)"
fi
zoomwarp_extra=()
[[ -z $analyses ]] || zoomwarp_extra=(--analyses "$analyses")

work=$(mktemp -d -t collection-ingest.XXXXXX)
trap 'rm -rf "$work"' EXIT

# ---- set A: 1224x816 crops at fixed offsets, spread over the corpus photographs big enough ------
# The offsets follow the R2 low-discrepancy sequence (Roberts 2018), so the k crops of one photo are
# spread over it and the same for every run.
make_set_a() {  # make_set_a DIR
  local dir=$1 photos=() file w h n i k count left top bands stem tmp
  mkdir -p "$dir"
  if (($(find "$dir" -maxdepth 1 -name '*.jpg' | wc -l) == set_a_count)); then
    log "set A: reusing the $set_a_count files in $dir"
    return
  fi
  find "$dir" -maxdepth 1 -name '*.jpg' -delete
  while IFS=$'\t' read -r file w h _; do
    [[ $file =~ \.(jpe?g|png)$ ]] || continue
    if ((w >= crop_w && h >= crop_h)); then photos+=("$file"); fi
  done < <(tail -n +2 "$corpus/MANIFEST.tsv")
  n=${#photos[@]}
  ((n)) || die "no corpus photograph of at least ${crop_w}x$crop_h for set A"
  log "set A: $set_a_count crops of ${crop_w}x$crop_h from $n photographs, JPEG Q85"
  tmp="$work/crop.v"
  for ((i = 0; i < n; i++)); do
    file="$corpus/${photos[i]}"
    [[ -f $file ]] || die "$file is in MANIFEST.tsv but not in $corpus"
    w=$(vipsheader -f width "$file"); h=$(vipsheader -f height "$file")
    bands=$(vipsheader -f bands "$file")
    count=$((set_a_count / n + (i < set_a_count % n ? 1 : 0)))
    stem=${photos[i]%.*}
    for ((k = 0; k < count; k++)); do
      read -r left top < <(awk -v k="$k" -v w=$((w - crop_w)) -v h=$((h - crop_h)) 'BEGIN {
        fx = 0.5 + k * 0.7548776662; fy = 0.5 + k * 0.5698402910
        printf "%d %d\n", (fx - int(fx)) * w, (fy - int(fy)) * h }')
      out=$(printf '%s/a%02d_%s_%d.jpg' "$dir" "$i" "$stem" "$k")
      vips extract_area "$file" "$tmp" "$left" "$top" "$crop_w" "$crop_h"
      if ((bands == 2 || bands == 4)); then
        vips flatten "$tmp" "${out}[Q=85,strip]"
      else
        vips copy "$tmp" "${out}[Q=85,strip]"
      fi
    done
  done
  rm -f "$tmp"
  (($(find "$dir" -maxdepth 1 -name '*.jpg' | wc -l) == set_a_count)) || die "set A: did not make $set_a_count files"
}

# ---- set B: the corpus photographs of 0.5 to 16 MP, copied into a folder of their own -----------
make_set_b() {  # make_set_b DIR
  local dir=$1 file mp
  mkdir -p "$dir"
  while IFS=$'\t' read -r file _ _ mp _; do
    [[ $file =~ \.(jpe?g|png|tiff?|webp)$ ]] || continue
    if echo "$mp >= 0.5 && $mp <= 16" | bc -l | grep -q 1; then
      [[ -f $corpus/$file ]] || die "$file is in MANIFEST.tsv but not in $corpus"
      cp "$corpus/$file" "$dir/"
    fi
  done < <(tail -n +2 "$corpus/MANIFEST.tsv")
  (($(find "$dir" -maxdepth 1 -type f | wc -l))) || die "set B: no corpus photograph of 0.5 to 16 MP"
}

# ---- one measured run: appends "wall cpu rss_kb bytes level_bytes files" to its runs file -------
measure() {  # measure RUNS_FILE OUT_DIR EXPECTED_IMAGES KIND COMMAND...   (KIND: zoomwarp or vips)
  local runs=$1 out=$2 expected=$3 kind=$4 wall user sys rss bytes levels files got
  shift 4
  rm -rf "$out"
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" >"$work/run.log" 2>&1 ||
    { tail -n 30 "$work/run.log" >&2; die "failed: $*"; }
  if [[ $kind == zoomwarp ]]; then
    got=$(find "$out/images" -mindepth 1 -maxdepth 1 2>/dev/null | wc -l)
    levels=$(find "$out" -type f -name 'level_*.tif' -printf '%s\n' | awk '{ s += $1 } END { printf "%d\n", s }')
  else
    got=$(find "$out" -maxdepth 1 -name '*.dzi' | wc -l)
    levels=0
  fi
  ((got == expected)) || { tail -n 30 "$work/run.log" >&2; die "$* left $got images, not $expected"; }
  read -r wall user sys rss <"$work/time"
  bytes=$(du -sb "$out" | cut -f1)
  files=$(find "$out" -type f | wc -l)
  echo "$wall $(echo "$user + $sys" | bc) $rss $bytes $levels $files" >>"$runs"
  log "  $(basename "$runs" .runs): wall $wall s, cpu $(echo "$user + $sys" | bc) s, peak RSS $((rss / 1024)) MB, $((bytes / 1000)) kB"
  rm -rf "$out"
}

run_contender() {  # run_contender SET CONTENDER SET_DIR
  local set=$1 c=$2 dir=$3 files=() out="$work/out"
  files=("$dir"/*)
  local runs="$work/$set.$c.runs"
  case "$c" in
    bulk1 | bulk2)
      measure "$runs" "$out" "${#files[@]}" zoomwarp \
        "$zoomwarp_bin" ingest "$dir" --store "$out" --jobs "${c#bulk}" --quiet "${zoomwarp_extra[@]}" ;;
    each)
      # shellcheck disable=SC2016  # expanded by the inner bash
      measure "$runs" "$out" "${#files[@]}" zoomwarp bash -c '
        bin=$1 store=$2; shift 2
        extra=(); if [[ $1 != -- ]]; then extra=(--analyses "$1"); fi; shift
        for f; do "$bin" ingest "$f" --store "$store" --quiet "${extra[@]}" || exit 1; done' \
        _ "$zoomwarp_bin" "$out" "${analyses:---}" "${files[@]}" ;;
    vips)
      # shellcheck disable=SC2016
      measure "$runs" "$out" "${#files[@]}" vips bash -c '
        out=$1; shift; mkdir -p "$out"
        for f; do n=${f##*/}; vips dzsave "$f" "$out/${n%.*}" || exit 1; done' \
        _ "$out" "${files[@]}" ;;
  esac
}

# ---- tables ---------------------------------------------------------------------------------------
stat_of() {  # stat_of RUNS COLUMN -> "median min max"
  cut -d' ' -f"$2" "$1" | sort -g | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)], v[1], v[NR] }'
}
ratio() { echo "scale=2; $1 / $2" | bc | sed 's/^\./0./'; }
mb() { echo "scale=1; $1 / 1000000" | bc | sed 's/^\./0./'; }
label() {
  case "$1" in
    bulk1) echo "zoomwarp ingest DIR --jobs 1" ;;
    bulk2) echo "zoomwarp ingest DIR --jobs 2" ;;
    each) echo "zoomwarp ingest FILE, a process each" ;;
    vips) echo "vips dzsave FILE, a process each" ;;
  esac
}

report_set() {  # report_set SET DESCRIPTION SET_DIR
  local set=$1 desc=$2 dir=$3 n src_bytes mp c runs wall lo hi cpu rss rss_hi bytes levels files per_image
  local vi_wall="" vi_bytes="" wall_ratio bytes_ratio split
  n=$(find "$dir" -maxdepth 1 -type f | wc -l)
  src_bytes=$(find "$dir" -maxdepth 1 -type f -printf '%s\n' | awk '{ s += $1 } END { printf "%d\n", s }')
  mp=$(for f in "$dir"/*; do echo "$(vipsheader -f width "$f") * $(vipsheader -f height "$f")"; done |
    awk '{ s += $1 * $3 } END { printf "%.1f\n", s / 1e6 }')
  if [[ -f $work/$set.vips.runs ]]; then
    read -r vi_wall _ _ < <(stat_of "$work/$set.vips.runs" 1)
    read -r vi_bytes _ _ < <(stat_of "$work/$set.vips.runs" 4)
  fi
  echo
  echo "Set $set, $desc: $n files, $mp MP, $(mb "$src_bytes") MB; $rounds round$( ((rounds == 1)) || echo "s, interleaved")"
  echo
  echo "| | wall, median (range) | per image | CPU user+sys | peak RSS, median (max) | stored (× the source) | levels + other | files | wall ÷ vips | stored ÷ vips |"
  echo "|---|---|---:|---:|---|---|---|---:|---:|---:|"
  for c in "${contender_list[@]}"; do
    runs="$work/$set.$c.runs"
    read -r wall lo hi < <(stat_of "$runs" 1)
    read -r cpu _ _ < <(stat_of "$runs" 2)
    read -r rss _ rss_hi < <(stat_of "$runs" 3)
    read -r bytes _ _ < <(stat_of "$runs" 4)
    read -r levels _ _ < <(stat_of "$runs" 5)
    read -r files _ _ < <(stat_of "$runs" 6)
    per_image=$(echo "$wall * 1000 / $n" | bc)
    split="–"
    [[ $c == vips ]] || split="$(mb "$levels") MB + $(((bytes - levels + 500) / 1000)) kB"
    wall_ratio="–"; bytes_ratio="–"
    if [[ -n $vi_wall && $c != vips ]]; then
      wall_ratio="**$(ratio "$wall" "$vi_wall")×**"; bytes_ratio="$(ratio "$bytes" "$vi_bytes")×"
    fi
    echo "| $(label "$c") | $wall s ($lo–$hi) | $per_image ms | $cpu s | $((rss / 1024)) MB ($((rss_hi / 1024))) | $(mb "$bytes") MB ($(ratio "$bytes" "$src_bytes")×) | $split | $files | $wall_ratio | $bytes_ratio |"
  done
}

# ---- the sets, then the rounds ---------------------------------------------------------------------
declare -A set_dir set_desc
for s in "${set_list[@]}"; do
  if [[ $s == A ]]; then
    set_dir[A]=${keep_dir:+$keep_dir/collection_A}
    set_dir[A]=${set_dir[A]:-$work/collection_A}
    make_set_a "${set_dir[A]}"
    set_desc[A]="$set_a_count photographs of about 1 MP (${crop_w}x$crop_h crops of the corpus), JPEG Q85"
  else
    set_dir[B]=$work/collection_B
    make_set_b "${set_dir[B]}"
    set_desc[B]="the corpus photographs of 0.5–16 MP, as they are"
  fi
  log "set $s: $(find "${set_dir[$s]}" -maxdepth 1 -type f | wc -l) files in ${set_dir[$s]}"
done

# The load average before the first round (set A's making counts in it when it was just made;
# --keep it to leave that out): load the figures below cannot show.
load_before=$(cut -d' ' -f1-3 /proc/loadavg)
nc=${#contender_list[@]}
for ((r = 1; r <= rounds; r++)); do
  for s in "${set_list[@]}"; do
    log "round $r/$rounds, set $s"
    for ((i = 0; i < nc; i++)); do
      run_contender "$s" "${contender_list[(i + r - 1) % nc]}" "${set_dir[$s]}"
    done
  done
done

# ---- fixed costs: process start and one 64x64 JPEG, interleaved, median of five ---------------------
elapsed_ms() {  # elapsed_ms COMMAND... -> wall milliseconds of one run (its output discarded)
  local t0=$EPOCHREALTIME t1
  "$@" >/dev/null 2>"$work/fixed.err" || { cat "$work/fixed.err" >&2; die "failed: $*"; }
  t1=$EPOCHREALTIME
  awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f\n", (b - a) * 1000 }'
}
tiny_src=$(find "${set_dir[${set_list[0]}]}" -maxdepth 1 -type f | sort | head -n 1)
vips thumbnail "$tiny_src" "$work/tiny.jpg[Q=85,strip]" 64 --height 64 --crop centre
log "fixed costs: $fixed_runs runs each"
for ((i = 0; i < fixed_runs; i++)); do
  elapsed_ms "$zoomwarp_bin" --help >>"$work/fixed.zw_start"
  elapsed_ms vips --version >>"$work/fixed.vi_start"
  elapsed_ms "$zoomwarp_bin" ingest "$work/tiny.jpg" --store "$work/tiny_store" --quiet "${zoomwarp_extra[@]}" >>"$work/fixed.zw_tiny"
  mkdir -p "$work/tiny_dz"
  elapsed_ms vips dzsave "$work/tiny.jpg" "$work/tiny_dz/tiny" >>"$work/fixed.vi_tiny"
  rm -rf "$work/tiny_store" "$work/tiny_dz"
done
fixed_cell() {  # fixed_cell FILE -> "median ms (min–max)"
  read -r m lo hi < <(sort -g "$1" | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)], v[1], v[NR] }')
  echo "$m ms ($lo–$hi)"
}
fixed_median() { sort -g "$1" | awk '{ v[NR] = $1 } END { print v[int((NR + 1) / 2)] }'; }

# ---- report ----------------------------------------------------------------------------------------
{
  echo "Collection ingest, zoomwarp against vips dzsave: $(nproc) cores, load before the rounds: $load_before"
  echo "zoomwarp: $zoomwarp_bin (ingest ${zoomwarp_extra[*]:-with its default --analyses}); $(vips --version)"
  for s in "${set_list[@]}"; do report_set "$s" "${set_desc[$s]}" "${set_dir[$s]}"; done
  cat <<EOF

vips dzsave ran with its defaults: 254-px tiles, overlap 1, JPEG Q75. zoomwarp stores JPEG tiles at
the source's quality (at most --tile-quality), a PNG source losslessly; "levels + other": its pyramid
(level_*.tif) and the rest of the store (manifests, analyses, folders). Stored: \`du -sb\` (folders
count). A loop's CPU is summed over its processes, its peak RSS is the largest process's.

Fixed costs, median of $fixed_runs (range), interleaved:

| | zoomwarp | vips | ratio |
|---|---|---|---:|
| process start: \`zoomwarp --help\`, \`vips --version\` | $(fixed_cell "$work/fixed.zw_start") | $(fixed_cell "$work/fixed.vi_start") | $(ratio "$(fixed_median "$work/fixed.zw_start")" "$(fixed_median "$work/fixed.vi_start")")× |
| one 64x64 JPEG: \`zoomwarp ingest\` (new store), \`vips dzsave\` | $(fixed_cell "$work/fixed.zw_tiny") | $(fixed_cell "$work/fixed.vi_tiny") | $(ratio "$(fixed_median "$work/fixed.zw_tiny")" "$(fixed_median "$work/fixed.vi_tiny")")× |
EOF
} >"$work/report.md"
cat "$work/report.md"
if [[ -n $out_file ]]; then cp "$work/report.md" "$out_file"; log "written to $out_file"; fi
