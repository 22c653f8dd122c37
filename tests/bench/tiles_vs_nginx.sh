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
# Not included: Debian's iipimage-server. It is a FastCGI program only (its package depends on
# libapache2-mod-fcgid | lighttpd), so measuring it would need an extra front end (lighttpd or
# Apache) installed and configured, and the front end's cost would be part of the figure. This
# script installs nothing.
#
# Run `tests/bench/tiles_vs_nginx.sh --help` for the options.
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"

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

# CPU time (user + system, in clock ticks) of a process and its direct children: zoomwarp's threads
# are all in its own /proc/PID/stat, nginx's work is done by the workers under the master.
cpu_ticks() {
  local pid total=0 t
  for pid in "$1" $(pgrep -P "$1" 2>/dev/null || true); do
    # Fields after "(comm)": state is 1, utime 12, stime 13.
    t=$(awk '{ sub(/^.*\) /, ""); print $12 + $13 }' "/proc/$pid/stat" 2>/dev/null || echo 0)
    total=$((total + t))
  done
  echo "$total"
}

# Busy CPU time of the whole machine (clock ticks: user, nice, system, irq, softirq, steal). Minus
# the server's and wrk's own, it shows how much else ran during a run: on 2 cores any other load
# (a compiler, another benchmark) lowers both servers' figures, not always by the same amount.
machine_busy_ticks() { awk '/^cpu / { print $2 + $3 + $4 + $7 + $8 + $9; exit }' /proc/stat; }

# ---- zoomwarp ----------------------------------------------------------------------------------
zoomwarp_port=""

start_zoomwarp() {
  log "ingesting $image"
  "$zoomwarp_bin" ingest "$image" --store "$work/store" --id "$image_id" --quiet >/dev/null
  # --port 0: the kernel picks a free port, which the 'listening' log line reports.
  "$zoomwarp_bin" serve --host 127.0.0.1 --port 0 --store "$work/store" --log-requests 0 \
    2>"$work/zoomwarp.log" >/dev/null &
  zoomwarp_pid=$!
  local _
  for _ in $(seq 100); do
    zoomwarp_port=$(grep '"msg":"listening"' "$work/zoomwarp.log" | sed -n 's/.*"port":\([0-9]*\).*/\1/p' | head -n 1 || true)
    [ -n "$zoomwarp_port" ] && break
    kill -0 "$zoomwarp_pid" 2>/dev/null || die "zoomwarp serve exited during start-up"
    sleep 0.1
  done
  [ -n "$zoomwarp_port" ] || die "zoomwarp did not report its port within 10 s"
  log "zoomwarp (pid $zoomwarp_pid) on 127.0.0.1:$zoomwarp_port"
}

# Response-cache misses so far: used to check that wrk only ever hit the cache.
zoomwarp_cache_misses() {
  curl -sf "http://127.0.0.1:$zoomwarp_port/metrics" |
    awk '/^zoomwarp_cache_misses_total\{cache="response"\}/ { printf "%d\n", $2 }'
}

# ---- tile list ---------------------------------------------------------------------------------
tile_count=0
level_list=""

# Writes $work/paths.txt: every tile of the $levels highest DZI levels, computed from the
# descriptor the way a viewer does (level L is ceil(W / 2^(maxLevel-L)) wide).
build_tile_list() {
  local dzi w h ts max_level size l scale lw lh cols rows c r
  dzi=$(curl -sSf "http://127.0.0.1:$zoomwarp_port/dzi/$image_id.dzi") || die "could not fetch the DZI descriptor"
  w=$(sed -n 's/.*Width="\([0-9]*\)".*/\1/p' <<<"$dzi")
  h=$(sed -n 's/.*Height="\([0-9]*\)".*/\1/p' <<<"$dzi")
  ts=$(sed -n 's/.*TileSize="\([0-9]*\)".*/\1/p' <<<"$dzi")
  if [ -z "$w" ] || [ -z "$h" ] || [ -z "$ts" ]; then die "unexpected DZI descriptor: $dzi"; fi
  size=$(( w > h ? w : h )); max_level=0
  while [ $(( 1 << max_level )) -lt "$size" ]; do max_level=$((max_level + 1)); done
  [ "$levels" -le $((max_level + 1)) ] || levels=$((max_level + 1))

  : >"$work/paths.txt"
  for ((l = max_level - levels + 1; l <= max_level; l++)); do
    scale=$(( 1 << (max_level - l) ))
    lw=$(( (w + scale - 1) / scale )); lh=$(( (h + scale - 1) / scale ))
    cols=$(( (lw + ts - 1) / ts )); rows=$(( (lh + ts - 1) / ts ))
    for ((r = 0; r < rows; r++)); do
      for ((c = 0; c < cols; c++)); do
        echo "/dzi/${image_id}_files/$l/${c}_${r}.jpg"
      done
    done >>"$work/paths.txt"
    level_list+="${level_list:+,}$l"
  done
  tile_count=$(wc -l <"$work/paths.txt")
  log "image ${w}x${h}, tile size $ts, levels $level_list of 0-$max_level: $tile_count tiles"
}

# Fetches every tile once from zoomwarp over one keep-alive connection: this renders and caches
# them in zoomwarp, and the saved bodies become nginx's docroot, byte for byte the same responses.
fetch_tiles() {
  local p codes
  while read -r p; do
    printf 'url = "http://127.0.0.1:%s%s"\noutput = "%s%s"\n' "$zoomwarp_port" "$p" "$work/docroot" "$p"
  done <"$work/paths.txt" >"$work/curl.cfg"
  codes=$(curl -sS --fail --fail-early --create-dirs -K "$work/curl.cfg" -w '%{http_code}\n') ||
    die "fetching the tiles from zoomwarp failed"
  [ "$(grep -c '^200$' <<<"$codes")" -eq "$tile_count" ] || die "not every tile came back 200 from zoomwarp"
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
# Each wrk thread walks the whole tile list in order (from its own starting point, so the threads
# do not ask for the same tile at the same moment), pre-formatting the requests in init() to keep
# Lua work per request small. done() prints one machine-readable line. No response() function:
# defining it makes wrk parse every body, which would cost client CPU on a 2-core machine. wrk
# counts statuses >= 400 in errors.status; 3xx cannot occur (no conditional requests are sent).
write_wrk_script() {
  cat >"$work/tiles.lua" <<'EOF'
local reqs, n, i = {}, 0, 0
local threads = 0

function setup(thread)
  thread:set("thread_index", threads)
  threads = threads + 1
end

function init(args)
  for path in io.lines(args[1]) do
    n = n + 1
    reqs[n] = wrk.format("GET", path)
  end
  i = (thread_index * 7919) % n   -- spread the threads' starting points over the list
end

function request()
  i = i % n + 1
  return reqs[i]
end

function done(summary, latency, requests)
  local e = summary.errors
  io.write(string.format(
    "WRK_RESULT requests=%d duration_us=%d bytes=%d p50_us=%d p99_us=%d max_us=%d connect=%d read=%d write=%d status=%d timeout=%d\n",
    summary.requests, summary.duration, summary.bytes, latency:percentile(50), latency:percentile(99),
    latency.max, e.connect, e.read, e.write, e.status, e.timeout))
end
EOF
}

# run_wrk NAME PID PORT SECONDS -> sets wrk_rps, wrk_p99_ms, wrk_p50_ms, srv_cores, wrk_cores,
# other_cores and fails the benchmark on any socket error or error status.
run_wrk() {
  local name=$1 pid=$2 port=$3 secs=$4 out="$work/wrk_$1.out" ticks0 ticks1 busy0 busy1 hz line
  hz=$(getconf CLK_TCK)
  ticks0=$(cpu_ticks "$pid"); busy0=$(machine_busy_ticks)
  # bash's `time` gives wrk's own CPU use: with 2 cores, wrk competes with the server for them.
  local TIMEFORMAT='%U %S'
  { time wrk --latency -t "$threads" -c "$connections" -d "${secs}s" -s "$work/tiles.lua" \
      "http://127.0.0.1:$port" -- "$work/paths.txt" >"$out" 2>&1; } 2>"$work/wrk_time" ||
    { cat "$out" >&2; die "wrk failed against $name"; }
  ticks1=$(cpu_ticks "$pid"); busy1=$(machine_busy_ticks)
  [ "$verbose" -eq 0 ] || sed 's/^/    /' "$out" >&2
  line=$(grep '^WRK_RESULT ' "$out") || { cat "$out" >&2; die "no result from wrk against $name"; }

  local requests duration_us p50 p99 connect read write status timeout
  requests=$(field requests "$line"); duration_us=$(field duration_us "$line")
  p50=$(field p50_us "$line"); p99=$(field p99_us "$line")
  connect=$(field connect "$line"); read=$(field read "$line"); write=$(field write "$line")
  status=$(field status "$line"); timeout=$(field timeout "$line")
  [ "$requests" -gt 0 ] || die "wrk made no requests against $name"
  [ "$status" -eq 0 ] || die "$name: $status responses with an error status (wrk: Non-2xx or 3xx)"
  [ $((connect + read + write + timeout)) -eq 0 ] ||
    die "$name: socket errors: connect $connect, read $read, write $write, timeout $timeout"

  wrk_rps=$(awk -v r="$requests" -v d="$duration_us" 'BEGIN { printf "%.0f", r / (d / 1e6) }')
  wrk_p50_ms=$(awk -v v="$p50" 'BEGIN { printf "%.3f", v / 1000 }')
  wrk_p99_ms=$(awk -v v="$p99" 'BEGIN { printf "%.3f", v / 1000 }')
  srv_cores=$(awk -v t=$((ticks1 - ticks0)) -v hz="$hz" -v d="$duration_us" 'BEGIN { printf "%.2f", t / hz / (d / 1e6) }')
  wrk_cores=$(awk -v d="$duration_us" '{ printf "%.2f", ($1 + $2) / (d / 1e6) }' "$work/wrk_time")
  other_cores=$(awk -v b=$((busy1 - busy0)) -v hz="$hz" -v d="$duration_us" -v s="$srv_cores" -v w="$wrk_cores" \
    'BEGIN { o = b / hz / (d / 1e6) - s - w; printf "%.2f", o < 0 ? 0 : o }')
}

field() { sed -n "s/.* $1=\([0-9]*\).*/\1/p" <<<" $2"; }

# ---- statistics and output ---------------------------------------------------------------------
median() { tr ' ' '\n' | grep . | sort -g | awk '{ v[NR] = $1 } END { if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", a / b }'; }
json_array() { local IFS=,; echo "[$*]"; }

# Per-round results, space-separated, indexed by round.
zw_rps=() zw_p99=() zw_cpu=() ng_rps=() ng_p99=() ng_cpu=() wrk_cpu_zw=() wrk_cpu_ng=() r_rps=() r_p99=() other=()

measure() {
  local r
  if [ "$warmup" -gt 0 ]; then
    log "warm-up: ${warmup}s each (not counted)"
    run_wrk zoomwarp "$zoomwarp_pid" "$zoomwarp_port" "$warmup"
    run_wrk nginx "$nginx_pid" "$nginx_port" "$warmup"
  fi
  local misses_before misses_after
  misses_before=$(zoomwarp_cache_misses)
  for ((r = 1; r <= rounds; r++)); do
    run_wrk zoomwarp "$zoomwarp_pid" "$zoomwarp_port" "$duration"
    zw_rps+=("$wrk_rps"); zw_p99+=("$wrk_p99_ms"); zw_cpu+=("$srv_cores"); wrk_cpu_zw+=("$wrk_cores"); other+=("$other_cores")
    log "round $r zoomwarp: $wrk_rps req/s, p50 $wrk_p50_ms ms, p99 $wrk_p99_ms ms (cores: server $srv_cores, wrk $wrk_cores, rest $other_cores)"
    run_wrk nginx "$nginx_pid" "$nginx_port" "$duration"
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
