#!/usr/bin/env bash
# zoomwarp side by side with its peers in one run, on one test image (issue 16): iipsrv (Debian's
# iipimage-server, FastCGI behind nginx) for IIIF regions and tiles, nginx serving `vips dzsave`'s
# Deep Zoom tiles as static files, `vips dzsave` for ingest, and the warp engine alone for /mesh.
# Prints one Markdown table (and writes it with the machine's description to --out FILE). A second
# case (issue 18), cold tiles: IIIF and Deep Zoom tiles with no cache on either side, zoomwarp
# sending its stored JPEG tiles as they are against iipsrv on a TIFF of the same quality and grid;
# its own section of the output. --only picks one case.
#
# One run: install what is missing (apt-get) -> build a ~127 MP JPEG from a photo -> build each
# server's pyramid, timed (zoomwarp ingest, vips dzsave, vips tiffsave) -> the view lists -> time
# the warp engine on the /mesh list's views (mesh_json_bench, if built) -> start zoomwarp twice (response cache off and on), iipsrv processes
# and one nginx -> check that peers and we answer the same requests with comparable images ->
# wrk every run in turn, the order reversed every other round -> medians, ratios, table.
# Everything lives in one temp folder that the EXIT trap removes, with every server we started,
# also on Ctrl-C or failure. All servers listen on 127.0.0.1 only.
#
# Run `scripts/bench-peers.sh --help` for the options; tests/bench/README.md explains the figures.
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/.." && pwd)
# shellcheck source=../tests/support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../tests/support/wrk_bench.sh
source "$repo_dir/tests/support/wrk_bench.sh"

# ---- defaults (see usage) -----------------------------------------------------------------------
duration=10           # seconds per measured wrk run
rounds=3              # rounds of every run; also how often each pyramid is built
warmup=2              # seconds of unmeasured load per run before round 1
megapixels=127        # size of the test image
connections=4         # wrk connections for computed answers (regions, viewports, meshes)
tile_connections=32   # wrk connections for cached tiles
tile_levels=3         # the N highest pyramid levels make up the tile lists
views=5000            # distinct views in the view list
seed=16               # of the view list's random numbers
quality=85            # JPEG quality of every answer (zoomwarp's default)
iipsrv_processes=$(nproc)
all_cases=(peers cold_tiles)
cases=("${all_cases[@]}")
screen_w=480 screen_h=360
photo=""
out_file=""
install=1
verbose=0
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
mesh_json_bench_bin="$repo_dir/build/bin/mesh_json_bench"
nginx_bin=/usr/sbin/nginx
iipsrv_bin=/usr/lib/iipimage-server/iipsrv.fcgi
image_id=bench
packages=(nginx-light wrk iipimage-server libvips-tools time curl jq procps)

usage() {
  cat <<EOF
usage: scripts/bench-peers.sh [OPTIONS]

Benchmarks zoomwarp against its peers on one ~127 MP test image and prints a Markdown table:
ICAZ /viewport against iipsrv's plain IIIF region, method=traditional and retarget-zoom against
our own IIIF region, /mesh against the warp engine alone, cached Deep Zoom tiles against nginx
serving vips dzsave's files, IIIF tiles (cached) against iipsrv, plain IIIF regions, and ingest
against vips dzsave (wall time, peak RSS, bytes on disk): the case "peers". The case
"cold_tiles": IIIF and Deep Zoom tiles with no cache on either side (zoomwarp --response-cache 0
sending its stored JPEG tiles as they are, iipsrv with MAX_IMAGE_CACHE_SIZE=0 on a JPEG TIFF of
the quality zoomwarp stored), every tile of the levels both hold, in a seeded random order, in
its own section. Each figure is the median over the rounds; ratios are ours/peer.
tests/bench/README.md explains how to read them.

Installs what is missing with apt-get (as root, or through sudo): ${packages[*]}.
Needs zoomwarp built (scripts/build.sh zoomwarp); uses mesh_json_bench for the engine's own time
on the /mesh list's views if it is built (scripts/build.sh mesh_json_bench), else that cell says
so. To measure the build the container ships: CMAKE_BUILD_TYPE=Release BUILD_DIR=build-release
scripts/build.sh zoomwarp mesh_json_bench, then --zoomwarp build-release/bin/zoomwarp
--mesh-json-bench build-release/bin/mesh_json_bench.

options:
  --duration SEC        length of each measured wrk run (default $duration)
  --rounds N            rounds of every run, and builds of every pyramid (default $rounds)
  --warmup SEC          unmeasured load per run before round 1, 0 = none (default $warmup)
  --photo FILE          the photo the test image is made of (default: ../shared/corpus/
                        nuthatch_tree_trunk.jpg if it exists, else samples/boats_lake_sunset.jpg)
  --megapixels N        size of the test image: copies of a crop of the photo, tiled (default $megapixels)
  --connections N       wrk connections for computed answers, one thread (default $connections)
  --tile-connections N  wrk connections for cached tiles, two threads (default $tile_connections)
  --tile-levels N       how many of the highest pyramid levels the tile lists cover (default $tile_levels)
  --views N             distinct views (regions, viewports, meshes) in the view list (default $views)
  --seed N              seed of the view list (default $seed)
  --quality Q           JPEG quality of zoomwarp's and iipsrv's answers and of dzsave's tiles (default $quality)
  --iipsrv-processes N  iipsrv FastCGI processes, one request at a time each (default: cores, $iipsrv_processes)
  --only CASE[,CASE]    run only these cases: ${all_cases[*]} (default: all)
  --out FILE            also write the table, the settings and the machine to FILE (Markdown)
  --no-install          install nothing; fail if something is missing
  --zoomwarp PATH       zoomwarp binary (default build/bin/zoomwarp)
  --mesh-json-bench PATH  mesh_json_bench binary (default build/bin/mesh_json_bench)
  --verbose             also print wrk's own output of every run
  -h, --help            this text

A default run takes about 10 minutes on 2 cores: ~2 to build the image, the pyramids (once per
round) and the tile caches, ~8 for the 14 runs (10 peers, 4 cold_tiles) x (warmup + rounds x
duration); --only cold_tiles about 3. Run it on a quiet machine: it reports the CPU that
everything else used during each run and warns above 0.25 cores.
EOF
}

die() { echo "bench-peers: error: $*" >&2; exit 1; }
log() { echo "bench-peers: $*" >&2; }
# has_case CASE: whether CASE is among the cases to run (--only).
has_case() { [[ " ${cases[*]} " == *" $1 "* ]]; }

parse_args() {
  invocation="$*"
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --duration) duration=${2:?--duration needs a value}; shift 2 ;;
      --rounds) rounds=${2:?--rounds needs a value}; shift 2 ;;
      --warmup) warmup=${2:?--warmup needs a value}; shift 2 ;;
      --photo) photo=${2:?--photo needs a value}; shift 2 ;;
      --megapixels) megapixels=${2:?--megapixels needs a value}; shift 2 ;;
      --connections) connections=${2:?--connections needs a value}; shift 2 ;;
      --tile-connections) tile_connections=${2:?--tile-connections needs a value}; shift 2 ;;
      --tile-levels) tile_levels=${2:?--tile-levels needs a value}; shift 2 ;;
      --views) views=${2:?--views needs a value}; shift 2 ;;
      --seed) seed=${2:?--seed needs a value}; shift 2 ;;
      --quality) quality=${2:?--quality needs a value}; shift 2 ;;
      --iipsrv-processes) iipsrv_processes=${2:?--iipsrv-processes needs a value}; shift 2 ;;
      --only) IFS=, read -r -a cases <<<"${2:?--only needs a value}"; shift 2 ;;
      --out) out_file=${2:?--out needs a value}; shift 2 ;;
      --no-install) install=0; shift ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --mesh-json-bench) mesh_json_bench_bin=${2:?--mesh-json-bench needs a value}; shift 2 ;;
      --verbose) verbose=1; shift ;;
      *) die "unknown argument $1 (see --help)" ;;
    esac
  done
  local n
  for n in duration rounds warmup megapixels connections tile_connections tile_levels views seed quality iipsrv_processes; do
    [[ ${!n} =~ ^[0-9]+$ ]] || die "--${n//_/-} must be a whole number, got '${!n}'"
  done
  for n in duration rounds megapixels connections tile_levels views seed quality iipsrv_processes; do
    [ "${!n}" -ge 1 ] || die "--${n//_/-} must be at least 1"
  done
  [ "$tile_connections" -ge 2 ] || die "--tile-connections must be at least 2 (two wrk threads)"
  [ "$quality" -le 100 ] || die "--quality must be 1-100"
  [ "${#cases[@]}" -gt 0 ] || die "--only needs at least one case: ${all_cases[*]}"
  for n in "${cases[@]}"; do
    [[ " ${all_cases[*]} " == *" $n "* ]] || die "--only: unknown case '$n' (cases: ${all_cases[*]})"
  done
  if [ -z "$photo" ]; then
    photo="$repo_dir/../shared/corpus/nuthatch_tree_trunk.jpg"
    [ -f "$photo" ] || photo="$repo_dir/samples/boats_lake_sunset.jpg"
  fi
  [ -f "$photo" ] || die "no such photo: $photo"
  [ -x "$zoomwarp_bin" ] || die "zoomwarp binary not found at $zoomwarp_bin (scripts/build.sh zoomwarp)"
  # The tree's version before --out (perhaps a tracked file) is emptied for writing.
  zoomwarp_version=$(git -C "$repo_dir" rev-parse --short HEAD 2>/dev/null || echo unknown)
  git -C "$repo_dir" diff --quiet HEAD 2>/dev/null || zoomwarp_version+=" (with uncommitted changes)"
  if [ -n "$out_file" ]; then : >"$out_file" || die "cannot write $out_file"; fi
}

# ---- packages ----------------------------------------------------------------------------------
# Installs the missing packages without recommends. iipimage-server then pulls in apache2-bin and
# mod_fcgid (its Depends), and enables its own iipsrv.service (all interfaces, port 9000): where
# systemd runs, this script disables and stops that service again, since it starts its own iipsrv.
install_packages() {
  local p missing=() sudo_cmd=()
  for p in "${packages[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ "${#missing[@]}" -gt 0 ] || return 0
  [ "$install" -eq 1 ] || die "missing packages: ${missing[*]} (run without --no-install to install them)"
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  log "installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q >&2
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}" >&2
  if [[ " ${missing[*]} " == *" iipimage-server "* ]] && [ -d /run/systemd/system ]; then
    log "disabling the iipsrv.service that iipimage-server enabled (this script runs its own iipsrv)"
    "${sudo_cmd[@]}" systemctl disable --now iipsrv.service >&2 || log "WARNING: could not disable iipsrv.service"
  fi
}

# ---- process control ---------------------------------------------------------------------------
work=""               # the one temp folder: images, pyramids, configs, lists, wrk outputs
zw_computed_pid="" zw_computed_port=""   # zoomwarp with --response-cache 0: every answer computed
zw_cached_pid="" zw_cached_port=""       # zoomwarp with its default response cache
zw_cold_pid="" zw_cold_port=""           # zoomwarp for cold tiles: response cache off, DZI 256/0
nginx_pid="" nginx_port=""
iipsrv_pids=()        # every iipsrv process, for cleanup

cleanup() {
  local rc=$? pid
  trap - EXIT INT TERM
  stop_process "$nginx_pid"
  for pid in "${iipsrv_pids[@]}"; do stop_process "$pid"; done
  stop_process "$zw_computed_pid"
  stop_process "$zw_cached_pid"
  stop_process "$zw_cold_pid"
  if [ -n "$work" ] && [ -d "$work" ]; then
    if [ "$rc" -ne 0 ]; then
      local f
      for f in "$work"/nginx/error.log "$work"/zoomwarp_*.log "$work"/iipsrv_*.log; do
        [ -s "$f" ] || continue
        log "last lines of $(basename "$f"):"; tail -n 20 "$f" >&2
      done
    fi
    rm -rf "$work"
  fi
  exit "$rc"
}

# ---- the test image ----------------------------------------------------------------------------
image="" image_w=0 image_h=0 image_note=""

# n x n copies of a centred crop of the photo, about $megapixels MP with the photo's aspect
# (copies of a real photograph: real JPEG statistics and real content for the warp, at any size).
make_test_image() {
  local pw ph plan n cw ch
  pw=$(vipsheader -f width "$photo"); ph=$(vipsheader -f height "$photo")
  plan=$(awk -v w="$pw" -v h="$ph" -v mp="$megapixels" 'BEGIN {
    k = sqrt(mp * 1e6 / (w * h)); n = int(k); if (n < k) n++
    cw = int(w * k / n + 0.5); ch = int(h * k / n + 0.5)
    if (cw > w) cw = w; if (ch > h) ch = h
    print n, cw, ch }')
  read -r n cw ch <<<"$plan"
  image="$work/$image_id.jpg"
  vips crop "$photo" "$work/crop.v" $(( (pw - cw) / 2 )) $(( (ph - ch) / 2 )) "$cw" "$ch"
  vips replicate "$work/crop.v" "${image}[Q=90]" "$n" "$n"
  rm -f "$work/crop.v"
  image_w=$((n * cw)); image_h=$((n * ch))
  image_note="$(basename "$photo") ($pw×$ph): $n×$n copies of its central ${cw}×${ch}, ${image_w}×${image_h} = $(awk -v a="$image_w" -v b="$image_h" 'BEGIN { printf "%.1f", a * b / 1e6 }') MP, JPEG Q90, $(awk -v s="$(stat -c %s "$image")" 'BEGIN { printf "%.1f", s / 1e6 }') MB"
  log "test image: $image_note"
}

# ---- pyramids, timed ---------------------------------------------------------------------------
# Per tool, space-separated per round: wall s, CPU s (user + system), peak RSS MB, MB on disk.
declare -A ingest_wall ingest_cpu ingest_rss ingest_mb

# timed TOOL OUTPUT COMMAND...: runs COMMAND under GNU time (wall, CPU, peak RSS), then measures
# OUTPUT (file or folder) on disk.
timed() {
  local tool=$1 output=$2 wall rss user sys
  shift 2
  /usr/bin/time -f '%e %M %U %S' -o "$work/time.txt" "$@" >/dev/null 2>"$work/ingest.err" ||
    { cat "$work/ingest.err" >&2; die "$tool failed"; }
  read -r wall rss user sys <"$work/time.txt"
  ingest_wall[$tool]+="$wall "
  ingest_cpu[$tool]+="$(awk -v u="$user" -v s="$sys" 'BEGIN { printf "%.2f", u + s }') "
  ingest_rss[$tool]+="$(awk -v k="$rss" 'BEGIN { printf "%.0f", k / 1024 }') "
  ingest_mb[$tool]+="$(du -sb "$output" | awk '{ printf "%.1f", $1 / 1e6 }') "
  log "  $tool: ${wall} s, peak RSS $((rss / 1024)) MB"
}

stored_quality=""     # the JPEG quality of zoomwarp's stored tiles, and of iipsrv's TIFF
stored_subsampling="" # their chroma subsampling, "2×1" (horizontal × vertical)

# Reads the stored tiles' JPEG quality and subsampling from the ingested version's manifest.json
# (tiles/manifest.h): the test image is a JPEG, so --tile-compression auto must have stored JPEG.
read_stored_quality() {
  local manifest="$work/store/images/$image_id/manifest.json"
  stored_quality=$(jq -r '.jpeg.quality // empty' "$manifest") || die "cannot read $manifest"
  [ -n "$stored_quality" ] || die "zoomwarp stored no JPEG tiles ($manifest: compression $(jq -r .compression "$manifest"))"
  stored_subsampling=$(jq -r '.jpeg.chroma_subsampling | map(tostring) | join("×")' "$manifest")
}

# Each pyramid is built once per round, the tools taking turns; the last build of each is served.
# zoomwarp: its store (levels, analysis, warp models); nginx: dzsave's Deep Zoom files, the layout
# and tile geometry of ours (254 px, overlap 1) at the same URLs (case peers only); iipsrv: a tiled
# pyramidal TIFF, JPEG-compressed, 256 px tiles, as IIPImage's documentation recommends, at the
# quality zoomwarp stored its tiles with, so that both servers hold tiles of one quality and grid.
build_pyramids() {
  local r
  mkdir -p "$work/docroot/dzi" "$work/iip"
  for ((r = 1; r <= rounds; r++)); do
    log "building the pyramids, round $r of $rounds"
    rm -rf "$work/store" "$work/docroot/dzi/$image_id"* "$work/iip/$image_id.tif"
    timed zoomwarp "$work/store" "$zoomwarp_bin" ingest "$image" --store "$work/store" --id "$image_id" --quiet
    read_stored_quality
    if has_case peers; then
      timed dzsave "$work/docroot/dzi" vips dzsave "$image" "$work/docroot/dzi/$image_id" \
        --tile-size 254 --overlap 1 --suffix ".jpg[Q=$quality]"
    fi
    timed tiffsave "$work/iip/$image_id.tif" vips tiffsave "$image" "$work/iip/$image_id.tif" \
      --tile --pyramid --compression jpeg --Q "$stored_quality" --tile-width 256 --tile-height 256
  done
  log "zoomwarp stored JPEG tiles of quality $stored_quality (chroma subsampling $stored_subsampling); iipsrv's TIFF has the same"
}

# ---- the engine alone --------------------------------------------------------------------------
engine_ms="" engine_note=""

# The warp engine's own CPU time per /mesh view on the /mesh run's own list (mesh_json_bench's
# Engine/listed: the list's views cycled in-process on zoomwarp's store, the query parsed and the
# engine looked up as the server does, every view a zoom action whose coarse warp is computed or
# found as the server would), pinned to one core. Before any server starts, so that nothing
# competes with it. The list is cycled for as long as the measured runs take, so that the engine's
# caches are as warm as the server's.
time_engine() {
  if [ ! -x "$mesh_json_bench_bin" ]; then
    engine_note="mesh_json_bench not built (scripts/build.sh mesh_json_bench)"
    log "no mesh_json_bench at $mesh_json_bench_bin: the /mesh row has no engine time"
    return 0
  fi
  log "timing the warp engine alone on the /mesh list (mesh_json_bench Engine/listed)"
  local pin=()
  [ "$(nproc)" -lt 2 ] || pin=(taskset -c $(( $(nproc) - 1 )))
  "${pin[@]}" "$mesh_json_bench_bin" --store "$work/store" --image "$image_id" --views "$work/list_mesh_icaz.txt" \
    --benchmark_filter='^Engine/listed' --benchmark_min_time=$(( rounds * duration )) \
    --benchmark_format=json --benchmark_out="$work/engine_bench.json" >/dev/null 2>"$work/engine_bench.err" ||
    { cat "$work/engine_bench.err" >&2; die "mesh_json_bench failed"; }
  engine_ms=$(jq -r '.benchmarks[] | select(.name | startswith("Engine/listed")) | .cpu_time / 1000' "$work/engine_bench.json")
  [ -n "$engine_ms" ] || die "mesh_json_bench reported no Engine/listed benchmark"
  engine_ms=$(awk -v v="$engine_ms" 'BEGIN { printf "%.3f", v }')
  engine_note="mesh_json_bench Engine/listed: the /mesh list's views, same store, CPU per view on one core"
  log "  engine: $engine_ms ms per view"
}

# ---- servers -----------------------------------------------------------------------------------
iipsrv_sockets=()        # the iipsrv processes with their tile cache (case peers)
iipsrv_cached_pids=()
iipsrv_cold_sockets=()   # those with none (case cold_tiles)
iipsrv_cold_pids=()

start_zoomwarps() {
  if has_case peers; then
    zoomwarp_serve "$zoomwarp_bin" "$work/store" "$work/zoomwarp_computed.log" --response-cache 0 --jpeg-quality "$quality" ||
      die "zoomwarp (response cache off) did not start"
    zw_computed_pid=$zoomwarp_pid zw_computed_port=$zoomwarp_port
    zoomwarp_serve "$zoomwarp_bin" "$work/store" "$work/zoomwarp_cached.log" --jpeg-quality "$quality" ||
      die "zoomwarp (response cache on) did not start"
    zw_cached_pid=$zoomwarp_pid zw_cached_port=$zoomwarp_port
    log "zoomwarp: response cache off on 127.0.0.1:$zw_computed_port (pid $zw_computed_pid), on on 127.0.0.1:$zw_cached_port (pid $zw_cached_pid)"
  fi
  # Deep Zoom's grid made the stored one (256 px, no overlap), so that its tiles can be sent as
  # stored too, as iipsrv's Deep Zoom tiles are its TIFF's.
  if has_case cold_tiles; then
    zoomwarp_serve "$zoomwarp_bin" "$work/store" "$work/zoomwarp_cold.log" --response-cache 0 \
      --dzi-tile-size 256 --dzi-overlap 0 --jpeg-quality "$quality" || die "zoomwarp (cold tiles) did not start"
    zw_cold_pid=$zoomwarp_pid zw_cold_port=$zoomwarp_port
    log "zoomwarp for cold tiles (--response-cache 0 --dzi-tile-size 256 --dzi-overlap 0) on 127.0.0.1:$zw_cold_port (pid $zw_cold_pid)"
  fi
}

# iipsrv handles one request at a time per process (its FastCGI loop), so it runs as several
# processes, each single-threaded (OMP_NUM_THREADS=1: like one zoomwarp worker per request; its
# OpenMP threads would otherwise compete with the other processes), each on its own Unix socket
# (TCP without keep-alive would leave a TIME_WAIT port behind per request). Its tile cache gets
# what zoomwarp's --tile-cache has by default, 256 MB, or, for cold tiles, 0 (iipsrv 1.1 takes 0:
# its cache then neither stores nor finds a tile, and its log says "maximum image cache size to
# 0MB"); no memcached (an empty MEMCACHED_SERVERS turns it off), no log; bilinear resampling (its
# default). JPEG at --quality, or for cold tiles at the stored tiles' quality, the quality of the
# tiles zoomwarp sends as stored: iipsrv decodes and encodes every tile, its answers should be
# neither worse nor smaller for it.
start_iipsrv() {
  if has_case peers; then
    start_iipsrv_processes iipsrv 256 "$quality"
    iipsrv_sockets=("${started_sockets[@]}") iipsrv_cached_pids=("${started_pids[@]}")
  fi
  if has_case cold_tiles; then
    start_iipsrv_processes iipsrv_cold 0 "$stored_quality"
    iipsrv_cold_sockets=("${started_sockets[@]}") iipsrv_cold_pids=("${started_pids[@]}")
  fi
  log "iipsrv $(dpkg-query -W -f='${Version}' iipimage-server): $iipsrv_processes processes per cache size (pids ${iipsrv_pids[*]})"
}

# start_iipsrv_processes NAME CACHE_MB JPEG_QUALITY: --iipsrv-processes iipsrv processes on
# sockets $work/NAME_I.sock; sets started_sockets and started_pids once every socket is open.
start_iipsrv_processes() {
  local name=$1 cache_mb=$2 jpeg_quality=$3 i sock
  started_sockets=() started_pids=()
  for ((i = 0; i < iipsrv_processes; i++)); do
    sock="$work/${name}_$i.sock"
    env FILESYSTEM_PREFIX="$work/iip/" JPEG_QUALITY="$jpeg_quality" MAX_IMAGE_CACHE_SIZE="$cache_mb" MEMCACHED_SERVERS= \
      OMP_NUM_THREADS=1 INTERPOLATION=1 MAX_CVT=5000 VERBOSITY=0 \
      "$iipsrv_bin" --bind "$sock" --backlog 1024 >"$work/${name}_$i.log" 2>&1 &
    iipsrv_pids+=($!) started_pids+=($!)
    started_sockets+=("$sock")
  done
  for sock in "${started_sockets[@]}"; do
    wait_until 10 test -S "$sock" || die "iipsrv did not open its socket $sock"
  done
}

start_nginx() {
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_answers || die "nginx did not start"
  log "nginx (pid $nginx_pid, $(pgrep -P "$nginx_pid" | wc -l) workers) on 127.0.0.1:$nginx_port"
}

# Any HTTP answer: what the docroot holds depends on the cases run.
nginx_answers() { [ "$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$nginx_port/")" != 000 ]; }

# iipsrv_upstream NAME SOCKET...: an nginx upstream block of those sockets, and a location at
# /fcgi-bin/NAME.fcgi that passes to it, as two variables for write_nginx_conf (upstream_conf,
# location_conf); nothing without sockets (nginx refuses an empty upstream).
iipsrv_upstream() {
  local name=$1 s
  shift
  [ $# -gt 0 ] || return 0
  # One connection per request: an iipsrv process serves one connection at a time, so a
  # kept-alive one would block the process for every other nginx worker.
  upstream_conf+="  upstream $name {"$'\n'"    least_conn;"$'\n'
  for s in "$@"; do upstream_conf+="    server unix:$s;"$'\n'; done
  upstream_conf+="  }"$'\n'
  location_conf+="    location = /fcgi-bin/$name.fcgi {"$'\n'"      fastcgi_pass $name;"$'\n'
  local param
  for param in QUERY_STRING:query_string REQUEST_METHOD:request_method REQUEST_URI:request_uri \
               SCRIPT_NAME:fastcgi_script_name SERVER_NAME:server_name SERVER_PORT:server_port \
               SERVER_PROTOCOL:server_protocol HTTP_HOST:http_host; do
    location_conf+="      fastcgi_param ${param%%:*} \$${param#*:};"$'\n'
  done
  location_conf+="    }"$'\n'
}

# One nginx for all peers: dzsave's files from the docroot, iipsrv through FastCGI at the path
# IIPImage's documentation uses, the cache-less iipsrv processes (case cold_tiles) at
# /fcgi-bin/iipsrv_cold.fcgi. The globals (foreground, pid file, user) and the logs' places
# come from nginx_start (tests/support/nginx.sh).
write_nginx_conf() {
  local upstream_conf="" location_conf=""
  nginx_port=$(pick_loopback_port) || return 1
  iipsrv_upstream iipsrv "${iipsrv_sockets[@]}"
  iipsrv_upstream iipsrv_cold "${iipsrv_cold_sockets[@]}"
  mkdir -p "$work/nginx/tmp"
  cat >"$work/nginx/nginx.conf" <<EOF
# Generated by scripts/bench-peers.sh, everything in $work.
worker_processes auto;      # one per core, like a production setup
events { worker_connections 1024; }
http {
  access_log off;           # zoomwarp runs with --log-requests 0 too
  sendfile on;
  tcp_nopush on;
  keepalive_timeout 65;
  keepalive_requests 100000000;  # wrk keeps its connections for the whole run; so does zoomwarp
  types { image/jpeg jpg; application/xml dzi; }  # instead of /etc/nginx/mime.types: self-contained
  default_type application/octet-stream;
  client_body_temp_path $work/nginx/tmp/body;   # the compiled-in ones are under root-owned /var/lib/nginx
  proxy_temp_path $work/nginx/tmp/proxy;
  fastcgi_temp_path $work/nginx/tmp/fastcgi;
  uwsgi_temp_path $work/nginx/tmp/uwsgi;
  scgi_temp_path $work/nginx/tmp/scgi;
$upstream_conf  server {
    listen 127.0.0.1:$nginx_port;
    root $work/docroot;
$location_conf  }
}
EOF
}

# ---- request lists -----------------------------------------------------------------------------
# The view list: $views random views of the screen, each a region of the image with the screen's
# aspect, inside the image, from 1:1 (the screen's own size) to as large as the image allows, its
# size log-uniform (uniform in zoom); integer corners so that the IIIF region is exact. One line
# per view: x y w h zoom cx cy, where (zoom, cx, cy) is the view of method=traditional showing
# exactly that region (warp/core/uniform_zoom.h: scale fit·(1/fit)^zoom, centred on (cx, cy)).
# A Park–Miller generator instead of awk's rand(), whose sequence differs between awks: the
# same seed gives the same list on every machine.
write_views() {
  awk -v n="$views" -v seed="$seed" -v W="$image_w" -v H="$image_h" -v sw="$screen_w" -v sh="$screen_h" '
    function gcd(a, b) { while (b) { t = b; b = a % b; a = t }; return a }
    function uniform() { s = (s * 16807) % 2147483647; return s / 2147483647 }
    BEGIN {
      s = seed % 2147483646 + 1
      q = sw / gcd(sw, sh)                      # region widths with an integer height
      lo = sw; hi = W < H * sw / sh ? W : H * sw / sh
      fit = sw / W < sh / H ? sw / W : sh / H
      for (i = 0; i < n; i++) {
        w = int(exp(log(lo) + uniform() * (log(hi) - log(lo))) / q) * q
        if (w < lo) w = lo
        h = w * sh / sw
        x = int(uniform() * (W - w + 1)); y = int(uniform() * (H - h + 1))
        z = fit >= 1 ? 1 : log(sw / w / fit) / log(1 / fit)
        if (z < 0) z = 0; if (z > 1) z = 1
        printf "%d %d %d %d %.9f %.1f %.1f\n", x, y, w, h, z, x + w / 2, y + h / 2
      }
    }' >"$work/views.txt"
  local screen="w=$screen_w&h=$screen_h" v="/v1/images/$image_id"
  awk -v id="$image_id.tif" -v s="$screen_w,$screen_h" '{ printf "/fcgi-bin/iipsrv.fcgi?IIIF=%s/%d,%d,%d,%d/%s/0/default.jpg\n", id, $1, $2, $3, $4, s }' "$work/views.txt" >"$work/list_iipsrv_region.txt"
  awk -v id="$image_id" -v s="$screen_w,$screen_h" '{ printf "/iiif/3/%s/%d,%d,%d,%d/%s/0/default.jpg\n", id, $1, $2, $3, $4, s }' "$work/views.txt" >"$work/list_region.txt"
  local route method
  for route in viewport mesh; do
    for method in icaz traditional retarget-zoom; do
      awk -v p="$v/$route" -v s="$screen" -v m="$method" '{ printf "%s?zoom=%s&cx=%s&cy=%s&%s%s\n", p, $5, $6, $7, s, m == "icaz" ? "" : "&method=" m }' \
        "$work/views.txt" >"$work/list_${route}_$method.txt"
    done
  done
  log "view list: $views views, seed $seed, regions $(awk 'NR == 1 || $3 < m { m = $3 } END { print m }' "$work/views.txt")–$(awk '$3 > m { m = $3 } END { print m }' "$work/views.txt") px wide"
}

# IIIF tiles of the $tile_levels largest scale factors of our info.json (full-resolution tiles
# first), in the two servers' URL forms; both tile their pyramids at 256 px, so every request is
# one stored tile for both. "w," sizes are valid IIIF 2 (iipsrv 1.1) and 3 (ours).
write_iiif_tiles() {
  local info ts
  info=$(curl -sSf "http://127.0.0.1:$zw_cached_port/iiif/3/$image_id/info.json") || die "no info.json from zoomwarp"
  ts=$(jq -r '.tiles[0].width' <<<"$info")
  [ "$ts" = "$(jq -r '.tiles[0].height' <<<"$info")" ] || die "zoomwarp's IIIF tiles are not square"
  jq -r ".tiles[0].scaleFactors | sort | .[0:$tile_levels][]" <<<"$info" |
    awk -v ts="$ts" -v W="$image_w" -v H="$image_h" '{
      f = $1; r = ts * f
      for (y = 0; y < H; y += r)
        for (x = 0; x < W; x += r) {
          w = W - x < r ? W - x : r; h = H - y < r ? H - y : r
          printf "%d,%d,%d,%d/%d,\n", x, y, w, h, int((w + f - 1) / f)
        }
    }' >"$work/iiif_tiles.txt"
  sed "s#^#/iiif/3/$image_id/#; s#\$#/0/default.jpg#" "$work/iiif_tiles.txt" >"$work/list_iiif_tiles.txt"
  sed "s#^#/fcgi-bin/iipsrv.fcgi?IIIF=$image_id.tif/#; s#\$#/0/default.jpg#" "$work/iiif_tiles.txt" >"$work/list_iipsrv_tiles.txt"
}

# Tile lists, and every tile fetched once from the cached zoomwarp (its response cache holds them
# afterwards) and from nginx (every dzsave file of the list must exist).
prepare_tiles() {
  dzi_tile_paths "http://127.0.0.1:$zw_cached_port" "$image_id" "$tile_levels" "$work/list_dzi.txt" || die "could not list the Deep Zoom tiles"
  write_iiif_tiles
  log "tile lists: $(wc -l <"$work/list_dzi.txt") Deep Zoom tiles (levels $dzi_levels), $(wc -l <"$work/list_iiif_tiles.txt") IIIF tiles; fetching each once"
  fetch_paths "http://127.0.0.1:$zw_cached_port" "$work/list_dzi.txt" || die "zoomwarp did not serve every Deep Zoom tile"
  fetch_paths "http://127.0.0.1:$zw_cached_port" "$work/list_iiif_tiles.txt" || die "zoomwarp did not serve every IIIF tile"
  fetch_paths "http://127.0.0.1:$nginx_port" "$work/list_dzi.txt" || die "nginx lacks some of dzsave's tiles for our tile list"
}

# The cold tile set: every tile of the Deep Zoom levels (256 px, no overlap: the stored grid, and
# iipsrv's Deep Zoom grid on its 256 px TIFF) whose scale factor both servers' IIIF info.json
# list, i.e. the levels both pyramids hold (iipsrv 1.1 answers a coarser Deep Zoom level with its
# smallest stored level, at the wrong size), in a random order from the Park–Miller generator
# seeded with --seed, so that consecutive requests are unrelated tiles as from many viewers. The
# same tiles in four URL forms: our Deep Zoom path and iipsrv's `?DeepZoom=ID.tif_files/L/C_R.jpg`;
# the IIIF tile of the same pixels (level L is scale factor s = 2^(max level - L): region C·256·s,
# R·256·s, up to 256·s wide and high, size "w,", w its width / s rounded up, the Deep Zoom tile's
# width) from us and from iipsrv.
write_cold_tiles() {
  local ours theirs levels
  ours=$(curl -sSf "http://127.0.0.1:$zw_cold_port/iiif/3/$image_id/info.json" | jq -c '.tiles[0].scaleFactors | sort') ||
    die "no info.json from zoomwarp"
  theirs=$(curl -sSf "http://127.0.0.1:$nginx_port/fcgi-bin/iipsrv_cold.fcgi?IIIF=$image_id.tif/info.json" | jq -c '.tiles[0].scaleFactors | sort') ||
    die "no info.json from iipsrv"
  # The common scale factors must be 1, 2, 4, …: the highest Deep Zoom levels, as many.
  levels=$(jq -n --argjson a "$ours" --argjson b "$theirs" '[$a[] | select(. as $f | $b | index($f))] as $c
    | if $c == [range($c | length) | pow(2; .)] then $c | length else empty end')
  [ -n "$levels" ] || die "zoomwarp's IIIF scale factors $ours and iipsrv's $theirs have no common 1, 2, 4, …"
  dzi_tile_paths "http://127.0.0.1:$zw_cold_port" "$image_id" "$levels" "$work/cold_dzi_all.txt" ||
    die "could not list the Deep Zoom tiles of the cold zoomwarp"
  awk -v seed="$seed" 'BEGIN { s = seed % 2147483646 + 1 }
    { s = (s * 16807) % 2147483647; printf "%.10f %s\n", s / 2147483647, $0 }' "$work/cold_dzi_all.txt" |
    sort -k1,1 | cut -d' ' -f2 >"$work/list_cold_dzi.txt"
  sed "s#^/dzi/\([^/]*\)_files/#/fcgi-bin/iipsrv_cold.fcgi?DeepZoom=\1.tif_files/#" "$work/list_cold_dzi.txt" >"$work/list_iipsrv_cold_dzi.txt"
  local max_level=0
  # shellcheck disable=SC2154  # dzi_width and dzi_height are set by dzi_tile_paths
  while [ $(( 1 << max_level )) -lt $(( dzi_width > dzi_height ? dzi_width : dzi_height )) ]; do max_level=$((max_level + 1)); done
  awk -F'[/_.]' -v M="$max_level" -v W="$dzi_width" -v H="$dzi_height" '{
      l = $(NF - 3); c = $(NF - 2); r = $(NF - 1); f = 2 ^ (M - l); t = 256 * f
      x = c * t; y = r * t; w = W - x < t ? W - x : t; h = H - y < t ? H - y : t
      printf "%d,%d,%d,%d/%d,\n", x, y, w, h, int((w + f - 1) / f)
    }' "$work/list_cold_dzi.txt" >"$work/cold_iiif_tiles.txt"
  sed "s#^#/iiif/3/$image_id/#; s#\$#/0/default.jpg#" "$work/cold_iiif_tiles.txt" >"$work/list_cold_iiif.txt"
  sed "s#^#/fcgi-bin/iipsrv_cold.fcgi?IIIF=$image_id.tif/#; s#\$#/0/default.jpg#" "$work/cold_iiif_tiles.txt" >"$work/list_iipsrv_cold_iiif.txt"
  cold_tiles_note="every tile of the $levels Deep Zoom levels $dzi_levels (IIIF scale factors $theirs, those both pyramids hold), $(wc -l <"$work/list_cold_dzi.txt") tiles, in a random order (seed $seed)"
  log "cold tiles: $cold_tiles_note"
}

# ---- same requests, comparable answers ---------------------------------------------------------
# mean_abs_diff A B: mean absolute difference of two images of equal size, in 8-bit levels.
mean_abs_diff() {
  vips subtract "$1" "$2" "$work/diff.v" && vips abs "$work/diff.v" "$work/absdiff.v" && vips avg "$work/absdiff.v"
  rm -f "$work/diff.v" "$work/absdiff.v"
}

# fetch NAME URL: saves one answer as $work/check_NAME.jpg and checks it is a JPEG of the screen's
# size (or SIZE, "WxH").
fetch_check() {
  local name=$1 url=$2 size=${3:-${screen_w}x$screen_h} f="$work/check_$1.jpg"
  curl -sSf -o "$f" "$url" || die "$name: $url failed"
  [ "$(vipsheader -f width "$f")x$(vipsheader -f height "$f")" = "$size" ] || die "$name: $url is not $size"
  [ "$(vipsheader -f vips-loader "$f")" = jpegload ] || die "$name: $url is not a JPEG"
}

# Peers and we must answer a list's requests with the same picture, or the comparison is
# meaningless: the first view as iipsrv's region, our region and our traditional viewport; the
# first Deep Zoom tile from nginx (dzsave) and from us; the first IIIF tile from both. Mean absolute
# differences above a few levels mean a different picture (a misplaced region, another level).
check_comparable() {
  local v1 zw="http://127.0.0.1:$zw_computed_port" ng="http://127.0.0.1:$nginx_port" d
  fetch_check iipsrv_region "$ng$(head -n 1 "$work/list_iipsrv_region.txt")"
  fetch_check region "$zw$(head -n 1 "$work/list_region.txt")"
  fetch_check traditional "$zw$(head -n 1 "$work/list_viewport_traditional.txt")"
  fetch_check icaz "$zw$(head -n 1 "$work/list_viewport_icaz.txt")"
  fetch_check retarget "$zw$(head -n 1 "$work/list_viewport_retarget-zoom.txt")"
  v1=$(head -n 1 "$work/views.txt")
  comparable_note="first view (region ${v1% * * *}): mean |difference| to our IIIF region, 8-bit levels:"
  for d in iipsrv_region traditional; do
    local m
    m=$(mean_abs_diff "$work/check_$d.jpg" "$work/check_region.jpg")
    comparable_note+=" $d $(printf '%.2f' "$m"),"
    awk -v m="$m" 'BEGIN { exit !(m > 6) }' && die "$d differs from our IIIF region of the same view by $m levels on average"
  done
  local tile size
  tile=$(head -n 1 "$work/list_dzi.txt")
  curl -sSf -o "$work/check_dzi_ours.jpg" "http://127.0.0.1:$zw_cached_port$tile" || die "zoomwarp did not serve $tile"
  size="$(vipsheader -f width "$work/check_dzi_ours.jpg")x$(vipsheader -f height "$work/check_dzi_ours.jpg")"
  fetch_check dzi_nginx "$ng$tile" "$size"
  m=$(mean_abs_diff "$work/check_dzi_nginx.jpg" "$work/check_dzi_ours.jpg")
  comparable_note+=" Deep Zoom tile $tile dzsave/ours $(printf '%.2f' "$m"),"
  awk -v m="$m" 'BEGIN { exit !(m > 6) }' && die "dzsave's $tile differs from ours by $m levels on average"
  tile=$(head -n 1 "$work/iiif_tiles.txt")
  curl -sSf -o "$work/check_iiif_ours.jpg" "http://127.0.0.1:$zw_cached_port$(head -n 1 "$work/list_iiif_tiles.txt")" || die "zoomwarp did not serve IIIF tile $tile"
  size="$(vipsheader -f width "$work/check_iiif_ours.jpg")x$(vipsheader -f height "$work/check_iiif_ours.jpg")"
  fetch_check iiif_iipsrv "$ng$(head -n 1 "$work/list_iipsrv_tiles.txt")" "$size"
  m=$(mean_abs_diff "$work/check_iiif_iipsrv.jpg" "$work/check_iiif_ours.jpg")
  comparable_note+=" IIIF tile $tile iipsrv/ours $(printf '%.2f' "$m")"
  awk -v m="$m" 'BEGIN { exit !(m > 6) }' && die "iipsrv's IIIF tile $tile differs from ours by $m levels on average"
  log "$comparable_note"
}

# Cold tiles compare only if iipsrv's Deep Zoom grid is ours (its descriptor: same size, 256 px,
# no overlap) and the list's first full-resolution 256 × 256 tile is the same picture from both,
# in both protocols (as above). Not an edge tile of a coarser level: vips halves a level's size
# rounding down, Deep Zoom (and our store) round up, so iipsrv answers some of those a pixel
# smaller (Deep Zoom) or resampled from its smaller level (IIIF) — its own picture of that tile.
check_cold_comparable() {
  local ng="http://127.0.0.1:$nginx_port" zw="http://127.0.0.1:$zw_cold_port" theirs ours kind m n
  theirs=$(curl -sSf "$ng/fcgi-bin/iipsrv_cold.fcgi?DeepZoom=$image_id.tif.dzi") || die "no Deep Zoom descriptor from iipsrv"
  ours=$(curl -sSf "$zw/dzi/$image_id.dzi") || die "no Deep Zoom descriptor from zoomwarp"
  for kind in Width Height TileSize Overlap; do
    [ "$(sed -n "s/.*$kind=\"\([0-9]*\)\".*/\1/p" <<<"$theirs")" = "$(sed -n "s/.*$kind=\"\([0-9]*\)\".*/\1/p" <<<"$ours")" ] ||
      die "iipsrv's Deep Zoom $kind differs from ours: $theirs against $ours"
  done
  n=$(grep -n -m 1 ',256,256/256,$' "$work/cold_iiif_tiles.txt" | cut -d: -f1)
  [ -n "$n" ] || die "the cold tile list has no full-resolution 256 × 256 tile"
  cold_comparable_note="tile $(sed -n "${n}p" "$work/cold_iiif_tiles.txt"), mean |difference| iipsrv/ours, 8-bit levels:"
  for kind in dzi iiif; do
    ours="$work/check_cold_${kind}_ours.jpg"
    curl -sSf -o "$ours" "$zw$(sed -n "${n}p" "$work/list_cold_$kind.txt")" || die "zoomwarp did not serve a cold $kind tile"
    fetch_check "cold_${kind}_iipsrv" "$ng$(sed -n "${n}p" "$work/list_iipsrv_cold_$kind.txt")" 256x256
    m=$(mean_abs_diff "$work/check_cold_${kind}_iipsrv.jpg" "$ours")
    cold_comparable_note+=" $kind $(printf '%.2f' "$m"),"
    awk -v m="$m" 'BEGIN { exit !(m > 6) }' && die "iipsrv's cold $kind tile differs from ours by $m levels on average"
  done
  cold_comparable_note=${cold_comparable_note%,}
  log "$cold_comparable_note"
}

# ---- measuring ---------------------------------------------------------------------------------
# The runs: name -> server, list, wrk threads, connections. Computed answers get one wrk thread,
# so that the view list is walked once in order: every request of a run is another view until the
# list wraps (5000 views by default), and --response-cache 0 keeps repeats from being cache hits.
# Cold tiles are computed answers too: one thread walking the shuffled tile set, no cache anywhere.
peers_runs=(iipsrv_region icaz_viewport region traditional_viewport retarget_viewport mesh
            nginx_dzi dzi iipsrv_iiif_tiles iiif_tiles)
cold_runs=(iipsrv_cold_iiif cold_iiif iipsrv_cold_dzi cold_dzi)
run_names=()
declare -A run_server run_list run_threads run_conns
declare -A res_rps res_p50 res_p99 res_srv_cores res_cpu_ms res_wrk_cores res_other res_bytes res_passthrough
other_max=0

define_runs() {
  local name
  if has_case peers; then run_names+=("${peers_runs[@]}"); fi
  if has_case cold_tiles; then run_names+=("${cold_runs[@]}"); fi
  for name in "${cold_runs[@]}"; do
    run_threads[$name]=1 run_conns[$name]=$connections run_server[$name]=zw_cold run_list[$name]=list_$name.txt
  done
  run_server[iipsrv_cold_iiif]=iipsrv_cold run_server[iipsrv_cold_dzi]=iipsrv_cold
  for name in iipsrv_region icaz_viewport region traditional_viewport retarget_viewport mesh; do
    run_threads[$name]=1 run_conns[$name]=$connections run_server[$name]=zw_computed
  done
  for name in nginx_dzi dzi iipsrv_iiif_tiles iiif_tiles; do
    run_threads[$name]=2 run_conns[$name]=$tile_connections run_server[$name]=zw_cached
  done
  run_server[iipsrv_region]=iipsrv run_server[iipsrv_iiif_tiles]=iipsrv run_server[nginx_dzi]=nginx
  run_list[iipsrv_region]=list_iipsrv_region.txt run_list[icaz_viewport]=list_viewport_icaz.txt
  run_list[region]=list_region.txt run_list[traditional_viewport]=list_viewport_traditional.txt
  run_list[retarget_viewport]=list_viewport_retarget-zoom.txt run_list[mesh]=list_mesh_icaz.txt
  run_list[nginx_dzi]=list_dzi.txt run_list[dzi]=list_dzi.txt
  run_list[iipsrv_iiif_tiles]=list_iipsrv_tiles.txt run_list[iiif_tiles]=list_iiif_tiles.txt
}

# tile_answer_counts URL: "PASSTHROUGH TILES" from zoomwarp's /metrics: the answers sent as stored
# tiles (zoomwarp_tiles_passthrough_total) and the Deep Zoom tile and IIIF image requests answered
# (zoomwarp_http_requests_total of those routes, every status).
tile_answer_counts() {
  curl -sf "$1/metrics" | awk '
    $1 == "zoomwarp_tiles_passthrough_total" { p = $2 }
    $1 ~ /^zoomwarp_http_requests_total\{route="(dzi_tile|iiif_image)",/ { t += $2 }
    END { printf "%d %d\n", p, t }'
}

# passthrough_percent "P0 T0" "P1 T1": the share of the tile answers between two tile_answer_counts
# that were sent as stored, in percent.
passthrough_percent() {
  local p0 t0 p1 t1
  read -r p0 t0 <<<"$1"; read -r p1 t1 <<<"$2"
  [ $((t1 - t0)) -gt 0 ] || die "zoomwarp counted no tile answers during a run"
  awk -v p=$((p1 - p0)) -v t=$((t1 - t0)) 'BEGIN { printf "%.1f", 100 * p / t }'
}

# measure_run NAME SECONDS [record]: one wrk run. The server's CPU is that of every process that
# answers: nginx and the iipsrv processes for iipsrv, nginx for its files, one zoomwarp for ours.
# Computed answers are checked to be 200 each (WRK_CHECK_STATUS); cached tiles count wrk's error
# statuses only, as checking costs client CPU there.
measure_run() {
  local name=$1 secs=$2 record=${3:-} pids url check=()
  case "${run_server[$name]}" in
    iipsrv) pids="$nginx_pid ${iipsrv_cached_pids[*]}"; url="http://127.0.0.1:$nginx_port" ;;
    nginx) pids=$nginx_pid; url="http://127.0.0.1:$nginx_port" ;;
    zw_computed) pids=$zw_computed_pid; url="http://127.0.0.1:$zw_computed_port" ;;
    zw_cached) pids=$zw_cached_pid; url="http://127.0.0.1:$zw_cached_port" ;;
    iipsrv_cold) pids="$nginx_pid ${iipsrv_cold_pids[*]}"; url="http://127.0.0.1:$nginx_port" ;;
    zw_cold) pids=$zw_cold_pid; url="http://127.0.0.1:$zw_cold_port" ;;
  esac
  [ "${run_threads[$name]}" -gt 1 ] || check=(check)
  local before=""
  [ "${run_server[$name]}" != zw_cold ] || before=$(tile_answer_counts "$url")
  run_wrk "$name" "$pids" "$url" "$secs" "$work/${run_list[$name]}" "${run_threads[$name]}" "${run_conns[$name]}" "${check[@]}" ||
    die "wrk against $name failed"
  [ "$verbose" -eq 0 ] || sed 's/^/    /' "$work/wrk_$name.out" >&2
  [ -n "$record" ] || return 0
  local bytes
  bytes=$(sed -n 's/.* bytes=\([0-9]*\).*/\1/p' "$work/wrk_$name.out")
  res_rps[$name]+="$wrk_rps " res_p50[$name]+="$wrk_p50_ms " res_p99[$name]+="$wrk_p99_ms "
  res_srv_cores[$name]+="$srv_cores " res_cpu_ms[$name]+="$srv_cpu_ms " res_wrk_cores[$name]+="$wrk_cores "
  res_other[$name]+="$other_cores " res_bytes[$name]+="$((bytes / wrk_requests)) "
  other_max=$(awk -v a="$other_max" -v b="$other_cores" 'BEGIN { print (b > a ? b : a) }')
  [ -z "$before" ] || res_passthrough[$name]+="$(passthrough_percent "$before" "$(tile_answer_counts "$url")") "
  log "  $(printf '%-21s' "$name") $(printf '%8s' "$wrk_rps") req/s  p50 $(printf '%7s' "$wrk_p50_ms") ms  p99 $(printf '%7s' "$wrk_p99_ms") ms  (cores: server $srv_cores, wrk $wrk_cores, rest $other_cores)"
}

measure() {
  local r name order=("${run_names[@]}") misses0 misses1
  if [ "$warmup" -gt 0 ]; then
    log "warm-up: ${warmup} s per run (not counted)"
    for name in "${run_names[@]}"; do measure_run "$name" "$warmup"; done
  fi
  cache_misses=0
  ! has_case peers || misses0=$(zoomwarp_cache_count "http://127.0.0.1:$zw_cached_port" misses response)
  for ((r = 1; r <= rounds; r++)); do
    log "round $r of $rounds"
    for name in "${order[@]}"; do measure_run "$name" "$duration" record; done
    # Reversed every other round: a run's place in the round (what ran just before it, the
    # machine's drift) evens out between peers and us.
    local reversed=() i
    for ((i = ${#order[@]} - 1; i >= 0; i--)); do reversed+=("${order[i]}"); done
    order=("${reversed[@]}")
  done
  has_case peers || return 0
  misses1=$(zoomwarp_cache_count "http://127.0.0.1:$zw_cached_port" misses response)
  cache_misses=$((misses1 - misses0))
  [ "$cache_misses" -eq 0 ] || log "WARNING: $cache_misses response-cache misses in the cached zoomwarp during the measured runs"
}

# ---- report ------------------------------------------------------------------------------------
# med VALUES [FORMAT]: the median of the space-separated VALUES, printf-formatted (default %.2f).
med() { fmt "$(echo "$1" | median)" "${2:-%.2f}"; }
plural() { if [ "$1" -eq 1 ]; then echo "1 $2"; else echo "$1 ${2}s"; fi; }
fmt() { awk -v v="$1" -v f="$2" 'BEGIN { printf f, v }'; }
# met CONDITION...: "met" if every awk condition (on numbers substituted in) holds, else "**not met**".
met() { local c; for c in "$@"; do awk "BEGIN { exit !($c) }" || { echo "**not met**"; return; }; done; echo met; }

# row WHAT PEER_LABEL PEER_RUN OUR_RUN GOAL_TEXT CONDITIONS: one table row; in CONDITIONS, p50r,
# rpsr and tail stand for the p50 and req/s ratios ours/peer and our p99/p50, cpur for our server
# CPU per request over the engine's time (PEER_RUN `engine`). A condition with a figure missing
# makes the verdict n/a.
row() {
  local what=$1 label=$2 peer=$3 ours=$4 goal=$5 conds=$6
  local op50 op99 orps pp50 pp99 prps p50r rpsr tail ptail c cpur=""
  op50=$(med "${res_p50[$ours]}"); op99=$(med "${res_p99[$ours]}"); orps=$(med "${res_rps[$ours]}" %.0f)
  tail=$(fmt "$(awk -v a="$op99" -v b="$op50" 'BEGIN { print a / b }')" %.1f)
  if [ "$peer" = engine ]; then
    pp50=${engine_ms:-}; prps="—"; ptail="—"
    if [ -n "$pp50" ]; then
      p50r=$(ratio "$op50" "$pp50"); cpur=$(ratio "$(med "${res_cpu_ms[$ours]}" %.3f)" "$pp50")
      goal+=" (server CPU $(med "${res_cpu_ms[$ours]}" %.3f) ms/request = ${cpur}× engine)"
    else p50r="—"; pp50="n/a"; fi
    rpsr="—"; pp99="—"
  else
    pp50=$(med "${res_p50[$peer]}"); pp99=$(med "${res_p99[$peer]}"); prps=$(med "${res_rps[$peer]}" %.0f)
    p50r=$(ratio "$op50" "$pp50"); rpsr=$(ratio "$orps" "$prps")
    ptail=$(fmt "$(awk -v a="$pp99" -v b="$pp50" 'BEGIN { print a / b }')" %.1f)
  fi
  local verdict
  c=${conds//p50r/$p50r}; c=${c//rpsr/$rpsr}; c=${c//tail/$tail}; c=${c//cpur/${cpur:-—}}
  # shellcheck disable=SC2086  # the conditions are separate words
  if [[ "$c" == *"—"* ]]; then verdict="n/a"; else verdict=$(met $c); fi
  printf '| %s | %s | %s / %s | %s | %s / %s | %s | %s | %s | %s (%s) | %s: %s |\n' \
    "$what" "$label" "$pp50" "$pp99" "$prps" "$op50" "$op99" "$orps" \
    "$p50r" "$rpsr" "$tail" "$ptail" "$goal" "$verdict"
}

ingest_row() {
  local tool=$1 label=$2 wall cpu rss mb
  wall=$(med "${ingest_wall[$tool]}"); cpu=$(med "${ingest_cpu[$tool]}")
  rss=$(med "${ingest_rss[$tool]}" %.0f); mb=$(med "${ingest_mb[$tool]}" %.1f)
  printf '| %s | %s | %s | %s | %s | %s | %s |\n' "$label" "$wall" "$cpu" "$rss" "$mb" \
    "$(ratio "$(med "${ingest_wall[zoomwarp]}")" "$wall")" "$(ratio "$(med "${ingest_rss[zoomwarp]}" %.0f)" "$rss")"
}

details_row() {
  local name=$1
  printf '| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n' "$name" "${run_conns[$name]}" \
    "$(med "${res_rps[$name]}" %.0f)" "$(med "${res_p50[$name]}")" "$(med "${res_p99[$name]}")" \
    "$(med "${res_srv_cores[$name]}")" "$(med "${res_cpu_ms[$name]}" %.3f)" "$(med "${res_wrk_cores[$name]}")" \
    "$(med "${res_other[$name]}")" "$(med "${res_bytes[$name]}" %.0f)" "$(sed 's/ $//; s# #/#g' <<<"${res_rps[$name]}")"
}

machine() {
  echo "- machine: $(lscpu | sed -n 's/^Model name: *//p' | head -n 1), $(nproc) cores, $(awk '/MemTotal/ { printf "%.1f GB", $2 / 1048576 }' /proc/meminfo) RAM, kernel $(uname -r)"
  # The build type of the binary measured (the container ships Release; scripts/build.sh makes
  # RelWithDebInfo unless CMAKE_BUILD_TYPE says otherwise).
  local build_type
  # a binary copied out of its build tree has no CMakeCache.txt beside it: "unknown", not a failure
  build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$(dirname "$zoomwarp_bin")/../CMakeCache.txt" 2>/dev/null || true)
  echo "- versions: zoomwarp $zoomwarp_version (${build_type:-unknown} build), $("$nginx_bin" -v 2>&1 | sed 's#.*/##; s#^#nginx #'), iipsrv $(dpkg-query -W -f='${Version}' iipimage-server) (Debian iipimage-server), $(vips --version), $(wrk -v 2>&1 | head -n 1 | awk '{ print $1, $2 }')"
}

# quiet_note RUN...: the most CPU everything else used during one of these runs, flagged above
# 0.25 cores.
quiet_note() {
  local name most=0 v
  for name in "$@"; do
    for v in ${res_other[$name]}; do most=$(awk -v a="$most" -v b="$v" 'BEGIN { print (b > a ? b : a) }'); done
  done
  echo "- CPU of everything else during the runs: up to $most cores$(awk -v o="$most" 'BEGIN { if (o > 0.25) print " — **the machine was not quiet: figures are low and noisy**" }')"
}

report_peers() {
  echo "## zoomwarp and its peers (scripts/bench-peers.sh, $(date -u +%Y-%m-%d))"
  echo
  machine
  echo "- test image: $image_note"
  echo "- runs: wrk, $duration s each, $(plural "$rounds" round) (the order reversed every other round), ${warmup} s warm-up per run; medians over rounds. Computed answers: 1 thread, $connections connections, $views distinct views (seed $seed), zoomwarp with --response-cache 0. Cached tiles: 2 threads, $tile_connections connections, every tile of the $tile_levels highest levels fetched once before."
  echo "- peers: iipsrv, $iipsrv_processes single-threaded FastCGI processes (Unix sockets) behind nginx \`fastcgi_pass\`, a JPEG-compressed tiled pyramidal TIFF (vips tiffsave, Q$stored_quality as zoomwarp's stored tiles, 256 px tiles), bilinear, 256 MB tile cache; nginx $("$nginx_bin" -v 2>&1 | sed 's#.*/##') (worker_processes auto, sendfile) serving vips dzsave's tiles (254 px, overlap 1). Answers: JPEG quality $quality everywhere (zoomwarp --jpeg-quality, iipsrv JPEG_QUALITY, dzsave Q)."
  echo "- $comparable_note"
  echo "- the engine alone: ${engine_note}. Its time is CPU time on one core, ours in that row is latency under $connections connections (queueing included), so the goal compares our server's CPU per /mesh request with it."
  quiet_note "${peers_runs[@]}"
  echo
  echo "| what | peer | peer p50 / p99 ms | peer req/s | ours p50 / p99 ms | ours req/s | p50 ours/peer | req/s ours/peer | p99/p50 ours (peer) | goal |"
  echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---|"
  row "ICAZ /viewport ${screen_w}×${screen_h} jpg" "iipsrv IIIF region → ${screen_w}×${screen_h}" iipsrv_region icaz_viewport \
    "p50 ≤ 1.3×, req/s ≥ 0.8×, p99 ≤ 5× p50" "p50r<=1.3 rpsr>=0.8 tail<=5"
  row "method=traditional /viewport" "our IIIF region, same region" region traditional_viewport "p50 ≤ 1.1×, p99 ≤ 5× p50" "p50r<=1.1 tail<=5"
  row "method=retarget-zoom /viewport" "our IIIF region, same zoom and centre" region retarget_viewport "p50 ≤ 1.1×, p99 ≤ 5× p50" "p50r<=1.1 tail<=5"
  row "/mesh JSON (ICAZ)" "the engine alone (CPU ms per view, below)" engine mesh "server CPU per request ≤ 1.3× engine" "cpur<=1.3"
  row "cached Deep Zoom tiles" "nginx, vips dzsave's files" nginx_dzi dzi "req/s ≥ 0.6×, p99 ≤ 5× p50" "rpsr>=0.6 tail<=5"
  row "IIIF tiles, response cache on" "iipsrv, the same tiles" iipsrv_iiif_tiles iiif_tiles "p99 ≤ 5× p50" "tail<=5"
  row "plain IIIF region → ${screen_w}×${screen_h}, no cache" "iipsrv, the same regions" iipsrv_region region "p99 ≤ 5× p50" "tail<=5"
  echo
  echo "Ingest of the test image, median of $(plural "$rounds" build) each (GNU time: wall, user + system CPU, peak RSS; \`du\` of what it wrote). Goal: zoomwarp wall ≤ 1.0× and peak RSS ≤ 1.5× vips dzsave's."
  echo
  echo "| pyramid | wall s | CPU s | peak RSS MB | on disk MB | zoomwarp wall / this | zoomwarp RSS / this |"
  echo "|---|---:|---:|---:|---:|---:|---:|"
  ingest_row zoomwarp "zoomwarp ingest (levels, analysis, warp models)"
  ingest_row dzsave "vips dzsave (Deep Zoom, Q$quality)"
  ingest_row tiffsave "vips tiffsave (iipsrv's TIFF, JPEG Q$stored_quality)"
  echo
  echo "Every run (medians): server CPU is that of all processes answering (nginx and iipsrv together for iipsrv), per second of run (cores) and per request; other cores: the rest of the machine (kernel, other processes); bytes per answer, headers included."
  echo
  echo "| run | connections | req/s | p50 ms | p99 ms | server cores | server CPU ms/req | wrk cores | other cores | bytes/answer | req/s per round |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  local name
  for name in "${peers_runs[@]}"; do details_row "$name"; done
  [ "$cache_misses" -eq 0 ] || { echo; echo "**Warning**: $cache_misses response-cache misses in the cached zoomwarp during the measured runs."; }
}

# cold_row WHAT PEER_RUN OUR_RUN: one row of the cold-tile table, iipsrv's figures and ours side by
# side with the ratios ours/iipsrv, and the share of our answers sent as stored tiles.
cold_row() {
  local what=$1 peer=$2 ours=$3 op50 orps pp50 prps
  op50=$(med "${res_p50[$ours]}"); orps=$(med "${res_rps[$ours]}" %.0f)
  pp50=$(med "${res_p50[$peer]}"); prps=$(med "${res_rps[$peer]}" %.0f)
  printf '| %s | %s / %s | %s | %s / %s | %s | %s | %s | %s / %s | %s / %s | %s %% |\n' "$what" \
    "$pp50" "$(med "${res_p99[$peer]}")" "$prps" "$op50" "$(med "${res_p99[$ours]}")" "$orps" \
    "$(ratio "$op50" "$pp50")" "$(ratio "$orps" "$prps")" \
    "$(med "${res_cpu_ms[$peer]}" %.3f)" "$(med "${res_cpu_ms[$ours]}" %.3f)" \
    "$(med "${res_bytes[$peer]}" %.0f)" "$(med "${res_bytes[$ours]}" %.0f)" "$(med "${res_passthrough[$ours]}" %.1f)"
}

report_cold_tiles() {
  echo "## Cold tiles: zoomwarp and iipsrv with no caches (issue 18; scripts/bench-peers.sh, $(date -u +%Y-%m-%d))"
  echo
  echo "- run as: \`scripts/bench-peers.sh${invocation:+ $invocation}\`"
  machine
  echo "- test image: $image_note"
  echo "- pyramids: zoomwarp's store with JPEG tiles, quality $stored_quality (from its manifest.json), YCbCr, chroma subsampling $stored_subsampling, 256 px; iipsrv's TIFF made after it with \`vips tiffsave --tile --pyramid --compression jpeg --Q $stored_quality\`, 256 px tiles (vips writes its JPEG tiles as RGB, without chroma subsampling)"
  echo "- servers, no cache on either side: zoomwarp \`--response-cache 0 --dzi-tile-size 256 --dzi-overlap 0\` (a Deep Zoom or IIIF tile that is one stored tile is sent as stored, api/README.md; its decoded-tile cache, used by the other answers, at its default); iipsrv, $iipsrv_processes single-threaded FastCGI processes behind nginx as in the peers case, \`MAX_IMAGE_CACHE_SIZE=0\` (no tile cache; it decodes each stored tile and encodes it again, JPEG_QUALITY $stored_quality: the stored tiles' quality, which ours are sent with)"
  echo "- tiles: $cold_tiles_note, the same set in both protocols: Deep Zoom (ours at /dzi, iipsrv's \`?DeepZoom=$image_id.tif_files/L/C_R.jpg\`) and the IIIF tile of the same pixels (\`x,y,w,h/w,/0/default.jpg\`)"
  echo "- runs: wrk, $duration s each, $(plural "$rounds" round) (the order reversed every other round), ${warmup} s warm-up per run; medians over rounds; 1 thread, $connections connections walking the list in order, every answer checked to be a 200"
  echo "- $cold_comparable_note"
  quiet_note "${cold_runs[@]}"
  echo
  echo "| tiles, no cache | iipsrv p50 / p99 ms | iipsrv req/s | ours p50 / p99 ms | ours req/s | p50 ours/iipsrv | req/s ours/iipsrv | server CPU ms/req iipsrv / ours | bytes/answer iipsrv / ours | ours sent as stored |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
  cold_row "IIIF tiles" iipsrv_cold_iiif cold_iiif
  cold_row "Deep Zoom tiles (256 px, no overlap)" iipsrv_cold_dzi cold_dzi
  echo
  echo "\"Sent as stored\": zoomwarp_tiles_passthrough_total over the Deep Zoom tile and IIIF image requests it answered during the run (/metrics before and after). Every run (medians), columns as in the peers case:"
  echo
  echo "| run | connections | req/s | p50 ms | p99 ms | server cores | server CPU ms/req | wrk cores | other cores | bytes/answer | req/s per round |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
  local name
  for name in "${cold_runs[@]}"; do details_row "$name"; done
}

report() {
  {
    if has_case peers; then report_peers; fi
    if has_case cold_tiles; then
      if has_case peers; then echo; fi
      report_cold_tiles
    fi
  } >"$work/report.md"
  echo
  cat "$work/report.md"
  if [ -n "$out_file" ]; then cp "$work/report.md" "$out_file"; log "wrote $out_file"; fi
  awk -v o="$other_max" 'BEGIN { exit !(o > 0.25) }' &&
    log "WARNING: other work used up to $other_max cores during the runs; the machine was not quiet, figures are low and noisy"
  return 0
}

main() {
  parse_args "$@"
  install_packages
  trap cleanup EXIT
  trap 'exit 130' INT      # exit runs the EXIT trap, which stops the servers
  trap 'exit 143' TERM
  work=$(mktemp -d "${TMPDIR:-/tmp}/bench-peers.XXXXXX")
  wrk_work_dir=$work
  local t0=$SECONDS
  log "load average before start: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"
  make_test_image
  build_pyramids
  if has_case peers; then write_views; time_engine; fi
  start_zoomwarps
  start_iipsrv
  start_nginx
  if has_case peers; then prepare_tiles; check_comparable; fi
  if has_case cold_tiles; then write_cold_tiles; check_cold_comparable; fi
  write_wrk_script
  define_runs
  log "set up in $((SECONDS - t0)) s; measuring takes about $(( ${#run_names[@]} * (warmup + rounds * (duration + 1)) )) s"
  measure
  report
  log "done in $((SECONDS - t0)) s"
}

main "$@"
