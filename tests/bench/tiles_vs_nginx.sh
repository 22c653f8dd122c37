#!/usr/bin/env bash
# Throughput and tail latency of zoomwarp serving *cached* Deep Zoom tiles, measured against nginx
# serving the very same tile files as static files. nginx with sendfile is about the fastest way
# to put a small file on a socket, so the ratio zoomwarp/nginx says how much the hot path
# (routing, cache lookup, response headers, HTTP/1.1 framing) costs beyond the unavoidable.
#
# One run: ingest an image into a temp store -> start zoomwarp -> fetch every tile of the highest
# DZI levels once (warms zoomwarp's response cache and writes the nginx docroot with the same
# /dzi/{id}_files/L/C_R.jpg layout) -> start nginx on that docroot -> wrk both servers alternately
# with the same URL list -> table + one JSON line. Everything binds to 127.0.0.1 and lives in one
# temp folder that the EXIT trap removes, with both servers, also on Ctrl-C or failure.
#
# This script installs nothing and measures only the tiles. scripts/bench-peers.sh is the whole
# side-by-side benchmark (iipsrv behind nginx, vips, viewports, meshes, ingest); both share
# tests/support/wrk_bench.sh.
#
# Run `tests/bench/tiles_vs_nginx.sh --help` for the options.
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../support/wrk_bench.sh
source "$repo_dir/tests/support/wrk_bench.sh"

# ---- defaults (see usage) -----------------------------------------------------------------------
duration=10       # seconds per measured wrk run
rounds=2          # rounds of (zoomwarp, nginx)
warmup=2          # seconds of unmeasured wrk load per server before round 1
connections=32
threads=2
levels=3          # the N highest DZI levels make up the URL list
verbose=0
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
nginx_bin=/usr/sbin/nginx
image=""
image_id=bench

usage() {
  cat <<EOF
usage: tests/bench/tiles_vs_nginx.sh [OPTIONS] [IMAGE]

Benchmarks zoomwarp's cached Deep Zoom tiles against nginx serving the same tiles as static
files, with wrk (keep-alive, --latency), alternating the two servers each round. Prints a table
(req/s, p99, ratio zoomwarp/nginx per round and median) and one JSON line at the end.

IMAGE defaults to ../shared/corpus/nuthatch_tree_trunk.jpg (relative to the repository) if it
exists, else samples/boats_lake_sunset.jpg.

options:
  --duration SEC      length of each measured wrk run (default $duration)
  --rounds N          rounds of zoomwarp then nginx; medians are over rounds (default $rounds)
  --warmup SEC        unmeasured wrk load per server before the first round, 0 = none (default $warmup)
  --connections N     wrk keep-alive connections (default $connections)
  --threads N         wrk threads (default $threads)
  --levels N          how many of the highest DZI levels to request (default $levels)
  --zoomwarp PATH     zoomwarp binary (default build/bin/zoomwarp)
  --nginx PATH        nginx binary (default $nginx_bin)
  --verbose           also print wrk's own output of every run
  -h, --help          this text

zoomwarp serve options other than host, port, store and request logging can be set through
their environment variables, e.g. ZOOMWARP_IO_THREADS=4 tests/bench/tiles_vs_nginx.sh.
Needs: wrk, nginx (Debian nginx-light), curl, awk; all of them in scripts/setup.sh.
EOF
}

die() { echo "tiles_vs_nginx: error: $*" >&2; exit 1; }
log() { echo "tiles_vs_nginx: $*" >&2; }

parse_args() {
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --duration) duration=${2:?--duration needs a value}; shift 2 ;;
      --rounds) rounds=${2:?--rounds needs a value}; shift 2 ;;
      --warmup) warmup=${2:?--warmup needs a value}; shift 2 ;;
      --connections) connections=${2:?--connections needs a value}; shift 2 ;;
      --threads) threads=${2:?--threads needs a value}; shift 2 ;;
      --levels) levels=${2:?--levels needs a value}; shift 2 ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --nginx) nginx_bin=${2:?--nginx needs a value}; shift 2 ;;
      --verbose) verbose=1; shift ;;
      -*) die "unknown option $1 (see --help)" ;;
      *) [ -z "$image" ] || die "only one IMAGE may be given"; image=$1; shift ;;
    esac
  done
  local n
  for n in duration rounds connections threads levels warmup; do
    [[ ${!n} =~ ^[0-9]+$ ]] || die "--$n must be a whole number, got '${!n}'"
  done
  if [ "$duration" -lt 1 ] || [ "$rounds" -lt 1 ] || [ "$levels" -lt 1 ]; then
    die "--duration, --rounds and --levels must be at least 1"
  fi
  if [ "$threads" -lt 1 ] || [ "$connections" -lt "$threads" ]; then die "wrk needs at least one connection per thread"; fi

  if [ -z "$image" ]; then
    image="$repo_dir/../shared/corpus/nuthatch_tree_trunk.jpg"
    [ -f "$image" ] || image="$repo_dir/samples/boats_lake_sunset.jpg"
  fi
  [ -f "$image" ] || die "no such image: $image"
  [ -x "$zoomwarp_bin" ] || die "zoomwarp binary not found at $zoomwarp_bin (build it first)"
  [ -x "$nginx_bin" ] || die "nginx not found at $nginx_bin (scripts/setup.sh installs nginx-light)"
  local tool
  for tool in wrk curl awk; do command -v "$tool" >/dev/null || die "$tool not found (scripts/setup.sh installs it)"; done
}

# ---- process control ---------------------------------------------------------------------------
work=""           # the one temp folder: store, docroot, nginx files, wrk script and outputs
zoomwarp_pid=""
nginx_pid=""

cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  stop_process "$nginx_pid"
  stop_process "$zoomwarp_pid"
  if [ -n "$work" ] && [ -d "$work" ]; then
    if [ "$rc" -ne 0 ] && [ -s "$work/nginx/error.log" ]; then log "nginx error.log:"; tail -n 20 "$work/nginx/error.log" >&2; fi
    if [ "$rc" -ne 0 ] && [ -s "$work/zoomwarp.log" ]; then log "zoomwarp log:"; tail -n 20 "$work/zoomwarp.log" >&2; fi
    rm -rf "$work"
  fi
  exit "$rc"
}

# ---- zoomwarp ----------------------------------------------------------------------------------
zoomwarp_port=""

start_zoomwarp() {
  log "ingesting $image"
  "$zoomwarp_bin" ingest "$image" --store "$work/store" --id "$image_id" --quiet >/dev/null
  zoomwarp_serve "$zoomwarp_bin" "$work/store" "$work/zoomwarp.log" || die "zoomwarp did not start"
  log "zoomwarp (pid $zoomwarp_pid) on 127.0.0.1:$zoomwarp_port"
}

# Response-cache misses so far: used to check that wrk only ever hit the cache.
zoomwarp_cache_misses() { zoomwarp_cache_count "http://127.0.0.1:$zoomwarp_port" misses response; }

# ---- tile list ---------------------------------------------------------------------------------
tile_count=0
level_list=""

# Writes $work/paths.txt: every tile of the $levels highest DZI levels.
build_tile_list() {
  dzi_tile_paths "http://127.0.0.1:$zoomwarp_port" "$image_id" "$levels" "$work/paths.txt" || die "could not list the tiles"
  level_list=$dzi_levels
  tile_count=$(wc -l <"$work/paths.txt")
  log "image ${dzi_width}x${dzi_height}, levels $level_list: $tile_count tiles"
}

# Fetches every tile once from zoomwarp over one keep-alive connection: this renders and caches
# them in zoomwarp, and the saved bodies become nginx's docroot, byte for byte the same responses.
fetch_tiles() {
  fetch_paths "http://127.0.0.1:$zoomwarp_port" "$work/paths.txt" "$work/docroot" || die "fetching the tiles from zoomwarp failed"
  [ "$(find "$work/docroot" -type f -name '*.jpg' | wc -l)" -eq "$tile_count" ] || die "docroot is missing tiles"
  log "fetched $tile_count tiles ($(du -sh "$work/docroot" | cut -f1) on disk)"
}

# ---- nginx -------------------------------------------------------------------------------------
nginx_port=""

# nginx (tests/support/nginx.sh) on a port below Linux's ephemeral range, where wrk's own client
# sockets live.
start_nginx() {
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_serves_tiles || die "nginx did not start"
  log "nginx (pid $nginx_pid, $(nginx_workers) workers) on 127.0.0.1:$nginx_port"
}

nginx_serves_tiles() { curl -s -o /dev/null "http://127.0.0.1:$nginx_port$(head -n 1 "$work/paths.txt")"; }

nginx_workers() { pgrep -P "$nginx_pid" | wc -l; }

# A plain static file server; the globals (foreground, pid file, user) and the logs' places come
# from nginx_start.
write_nginx_conf() {
  nginx_port=$(pick_loopback_port) || return 1
  mkdir -p "$work/nginx/tmp"
  cat >"$work/nginx/nginx.conf" <<EOF
# Generated by tests/bench/tiles_vs_nginx.sh: a plain static file server, everything in $work.
worker_processes auto;      # one per core, like a production setup
events { worker_connections 1024; }
http {
  access_log off;           # zoomwarp runs with --log-requests 0 too
  sendfile on;
  tcp_nopush on;
  keepalive_timeout 65;
  keepalive_requests 100000000;  # wrk keeps its connections for the whole run; so does zoomwarp
  types { image/jpeg jpg; } # instead of /etc/nginx/mime.types: self-contained
  default_type application/octet-stream;
  # The compiled-in temp paths are under root-owned /var/lib/nginx.
  client_body_temp_path $work/nginx/tmp/body;
  proxy_temp_path $work/nginx/tmp/proxy;
  fastcgi_temp_path $work/nginx/tmp/fastcgi;
  uwsgi_temp_path $work/nginx/tmp/uwsgi;
  scgi_temp_path $work/nginx/tmp/scgi;
  server {
    listen 127.0.0.1:$nginx_port;
    root $work/docroot;
  }
}
EOF
}

# Both servers must hand out the same bytes, or the comparison is meaningless.
check_same_tile() {
  local p
  p=$(head -n 1 "$work/paths.txt")
  curl -sSf -o "$work/check_nginx.jpg" "http://127.0.0.1:$nginx_port$p" || die "nginx did not serve $p"
  curl -sSf -o "$work/check_zoomwarp.jpg" "http://127.0.0.1:$zoomwarp_port$p" || die "zoomwarp did not serve $p"
  cmp -s "$work/check_nginx.jpg" "$work/check_zoomwarp.jpg" || die "nginx and zoomwarp serve different bytes for $p"
}

# ---- wrk ---------------------------------------------------------------------------------------
# run NAME PID SECONDS: wrk against one of the two servers with the tile list (run_wrk of
# tests/support/wrk_bench.sh: fails on any socket error or error status).
run() {
  local port
  port=$([ "$1" = nginx ] && echo "$nginx_port" || echo "$zoomwarp_port")
  run_wrk "$1" "$2" "http://127.0.0.1:$port" "$3" "$work/paths.txt" "$threads" "$connections" || die "wrk against $1 failed"
  [ "$verbose" -eq 0 ] || sed 's/^/    /' "$work/wrk_$1.out" >&2
}

# ---- statistics and output ---------------------------------------------------------------------
json_array() { local IFS=,; echo "[$*]"; }

# Per-round results, space-separated, indexed by round.
zw_rps=() zw_p99=() zw_cpu=() ng_rps=() ng_p99=() ng_cpu=() wrk_cpu_zw=() wrk_cpu_ng=() r_rps=() r_p99=() other=()

measure() {
  local r
  if [ "$warmup" -gt 0 ]; then
    log "warm-up: ${warmup}s each (not counted)"
    run zoomwarp "$zoomwarp_pid" "$warmup"
    run nginx "$nginx_pid" "$warmup"
  fi
  local misses_before misses_after
  misses_before=$(zoomwarp_cache_misses)
  for ((r = 1; r <= rounds; r++)); do
    run zoomwarp "$zoomwarp_pid" "$duration"
    zw_rps+=("$wrk_rps"); zw_p99+=("$wrk_p99_ms"); zw_cpu+=("$srv_cores"); wrk_cpu_zw+=("$wrk_cores"); other+=("$other_cores")
    log "round $r zoomwarp: $wrk_rps req/s, p50 $wrk_p50_ms ms, p99 $wrk_p99_ms ms (cores: server $srv_cores, wrk $wrk_cores, rest $other_cores)"
    run nginx "$nginx_pid" "$duration"
    ng_rps+=("$wrk_rps"); ng_p99+=("$wrk_p99_ms"); ng_cpu+=("$srv_cores"); wrk_cpu_ng+=("$wrk_cores"); other+=("$other_cores")
    log "round $r nginx:    $wrk_rps req/s, p50 $wrk_p50_ms ms, p99 $wrk_p99_ms ms (cores: server $srv_cores, wrk $wrk_cores, rest $other_cores)"
    r_rps+=("$(ratio "${zw_rps[-1]}" "${ng_rps[-1]}")"); r_p99+=("$(ratio "${zw_p99[-1]}" "${ng_p99[-1]}")")
  done
  misses_after=$(zoomwarp_cache_misses)
  # Every measured request should have been a response-cache hit; otherwise zoomwarp was partly
  # re-encoding tiles and the figure is not the cached path this benchmark is about.
  [ "${misses_after:-0}" -eq "${misses_before:-0}" ] ||
    log "WARNING: $((misses_after - misses_before)) zoomwarp response-cache misses during the measured runs"
}

report() {
  local r m_zw_rps m_ng_rps m_zw_p99 m_ng_p99 m_r_rps m_r_p99 m_zw_cpu m_ng_cpu m_other
  m_zw_rps=$(echo "${zw_rps[*]}" | median); m_ng_rps=$(echo "${ng_rps[*]}" | median)
  m_zw_p99=$(echo "${zw_p99[*]}" | median); m_ng_p99=$(echo "${ng_p99[*]}" | median)
  m_r_rps=$(echo "${r_rps[*]}" | median); m_r_p99=$(echo "${r_p99[*]}" | median)
  m_zw_cpu=$(echo "${zw_cpu[*]}" | median); m_ng_cpu=$(echo "${ng_cpu[*]}" | median)
  m_other=$(printf '%s\n' "${other[@]}" | sort -g | tail -n 1)

  echo
  echo "tiles_vs_nginx: $(basename "$image"), $tile_count tiles (DZI levels $level_list), wrk -t$threads -c$connections -d${duration}s, $rounds rounds, $(nproc) cores"
  printf '%-8s %14s %12s %14s %12s %10s %10s\n' round "zoomwarp r/s" "zw p99 ms" "nginx r/s" "ng p99 ms" "r/s ratio" "p99 ratio"
  for ((r = 0; r < rounds; r++)); do
    printf '%-8s %14s %12s %14s %12s %10s %10s\n' $((r + 1)) "${zw_rps[r]}" "${zw_p99[r]}" "${ng_rps[r]}" "${ng_p99[r]}" "${r_rps[r]}" "${r_p99[r]}"
  done
  printf '%-8s %14.0f %12.3f %14.0f %12.3f %10.3f %10.3f\n' median "$m_zw_rps" "$m_zw_p99" "$m_ng_rps" "$m_ng_p99" "$m_r_rps" "$m_r_p99"
  echo "ratios are zoomwarp/nginx per round (r/s: higher is better for zoomwarp; p99: lower is)."
  echo "CPU, cores (median): zoomwarp $m_zw_cpu, nginx $m_ng_cpu; wrk $(echo "${wrk_cpu_zw[*]}" | median) against zoomwarp, $(echo "${wrk_cpu_ng[*]}" | median) against nginx; everything else (kernel softirq, other processes) up to $m_other."
  if awk -v o="$m_other" 'BEGIN { exit !(o > 0.25) }'; then
    echo "WARNING: other work used up to $m_other cores during the runs; the machine was not quiet, figures are low and noisy."
  fi

  # One line for CI logs.
  printf '{"bench":"tiles_vs_nginx","date":"%s","host_cores":%d,"image":"%s","tiles":%d,"levels":[%s],' \
    "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$(nproc)" "$(basename "$image")" "$tile_count" "$level_list"
  printf '"wrk":{"threads":%d,"connections":%d,"duration_s":%d},"rounds":%d,"other_cores_max":%s,' \
    "$threads" "$connections" "$duration" "$rounds" "$m_other"
  printf '"zoomwarp":{"rps":%s,"p99_ms":%s,"cpu_cores":%s,"rps_median":%s,"p99_ms_median":%s},' \
    "$(json_array "${zw_rps[@]}")" "$(json_array "${zw_p99[@]}")" "$(json_array "${zw_cpu[@]}")" "$m_zw_rps" "$m_zw_p99"
  printf '"nginx":{"rps":%s,"p99_ms":%s,"cpu_cores":%s,"rps_median":%s,"p99_ms_median":%s},' \
    "$(json_array "${ng_rps[@]}")" "$(json_array "${ng_p99[@]}")" "$(json_array "${ng_cpu[@]}")" "$m_ng_rps" "$m_ng_p99"
  printf '"ratio":{"rps":%s,"p99":%s,"rps_median":%s,"p99_median":%s}}\n' \
    "$(json_array "${r_rps[@]}")" "$(json_array "${r_p99[@]}")" "$m_r_rps" "$m_r_p99"
}

main() {
  parse_args "$@"
  trap cleanup EXIT
  trap 'exit 130' INT      # exit runs the EXIT trap, which stops the servers
  trap 'exit 143' TERM
  work=$(mktemp -d "${TMPDIR:-/tmp}/tiles_vs_nginx.XXXXXX")
  wrk_work_dir=$work
  log "load average before start: $(cut -d' ' -f1-3 /proc/loadavg) on $(nproc) cores"

  start_zoomwarp
  build_tile_list
  fetch_tiles
  start_nginx
  check_same_tile
  write_wrk_script
  measure
  report
}

main "$@"
