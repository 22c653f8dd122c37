# shellcheck shell=bash
# shellcheck disable=SC2034  # the functions' results are globals that the callers read
# What the HTTP benchmark scripts (tests/bench/tiles_vs_nginx.sh, scripts/bench-peers.sh) share:
# starting `zoomwarp serve` on a free loopback port, listing and fetching Deep Zoom tiles, driving
# a server with wrk over a list of paths, and the CPU accounting that says how quiet the machine
# was. Sourced, not run, after tests/support/nginx.sh (wait_until, stop_process).
#
# Functions print their complaints to stderr and return non-zero; the caller decides to die.
# The caller sets `wrk_work_dir`, the temp folder where run_wrk keeps wrk's script and outputs.

wrk_work_dir=""

# ---- zoomwarp ----------------------------------------------------------------------------------

# zoomwarp_serve BIN STORE LOG [SERVE_FLAG...]: starts `zoomwarp serve` on 127.0.0.1 with
# --port 0 (the kernel picks a free port, which the 'listening' log line reports) and no request
# log; sets zoomwarp_pid and zoomwarp_port once it listens.
zoomwarp_serve() {
  local bin=$1 store=$2 logfile=$3 _
  shift 3
  "$bin" serve --host 127.0.0.1 --port 0 --store "$store" --log-requests 0 "$@" 2>"$logfile" >/dev/null &
  zoomwarp_pid=$!
  zoomwarp_port=""
  for _ in $(seq 200); do
    zoomwarp_port=$(sed -n 's/.*"msg":"listening".*"port":\([0-9]*\).*/\1/p' "$logfile" | head -n 1)
    [ -n "$zoomwarp_port" ] && return 0
    kill -0 "$zoomwarp_pid" 2>/dev/null || { cat "$logfile" >&2; echo "zoomwarp serve exited during start-up" >&2; return 1; }
    sleep 0.1
  done
  echo "zoomwarp did not report its port within 20 s" >&2
  return 1
}

# zoomwarp_cache_count URL KIND CACHE: zoomwarp_cache_KIND_total{cache="CACHE"} from /metrics
# (KIND hits or misses; CACHE response or tile), e.g. to check that a run only hit the cache.
zoomwarp_cache_count() {
  curl -sf "$1/metrics" | awk -v k="zoomwarp_cache_$2_total{cache=\"$3\"}" '$1 == k { printf "%d\n", $2 }'
}

# ---- Deep Zoom tiles ---------------------------------------------------------------------------

# dzi_tile_paths URL ID LEVELS OUT: writes to OUT the path of every tile of the LEVELS highest
# Deep Zoom levels of image ID, computed from the server's descriptor the way a viewer does
# (level L is ceil(W / 2^(maxLevel-L)) wide), one /dzi/ID_files/L/C_R.jpg a line; sets
# dzi_levels ("11,12,13"), dzi_width and dzi_height.
dzi_tile_paths() {
  local url=$1 id=$2 levels=$3 out=$4 dzi ts max_level=0 size l scale lw lh cols rows c r
  dzi=$(curl -sSf "$url/dzi/$id.dzi") || { echo "could not fetch the DZI descriptor" >&2; return 1; }
  dzi_width=$(sed -n 's/.*Width="\([0-9]*\)".*/\1/p' <<<"$dzi")
  dzi_height=$(sed -n 's/.*Height="\([0-9]*\)".*/\1/p' <<<"$dzi")
  ts=$(sed -n 's/.*TileSize="\([0-9]*\)".*/\1/p' <<<"$dzi")
  if [ -z "$dzi_width" ] || [ -z "$dzi_height" ] || [ -z "$ts" ]; then echo "unexpected DZI descriptor: $dzi" >&2; return 1; fi
  size=$(( dzi_width > dzi_height ? dzi_width : dzi_height ))
  while [ $(( 1 << max_level )) -lt "$size" ]; do max_level=$((max_level + 1)); done
  [ "$levels" -le $((max_level + 1)) ] || levels=$((max_level + 1))
  dzi_levels=""
  : >"$out"
  for ((l = max_level - levels + 1; l <= max_level; l++)); do
    scale=$(( 1 << (max_level - l) ))
    lw=$(( (dzi_width + scale - 1) / scale )); lh=$(( (dzi_height + scale - 1) / scale ))
    cols=$(( (lw + ts - 1) / ts )); rows=$(( (lh + ts - 1) / ts ))
    for ((r = 0; r < rows; r++)); do
      for ((c = 0; c < cols; c++)); do echo "/dzi/${id}_files/$l/${c}_${r}.jpg"; done
    done >>"$out"
    dzi_levels+="${dzi_levels:+,}$l"
  done
}

# fetch_paths URL PATHS [DOCROOT]: GETs every path of the file PATHS once, in order, over one
# keep-alive connection (this is what warms a response cache); with DOCROOT, also saves each body
# at DOCROOT/PATH. Fails unless every answer is a 200.
fetch_paths() {
  local url=$1 paths=$2 docroot=${3:-} p codes n
  n=$(wc -l <"$paths")
  while read -r p; do
    printf 'url = "%s%s"\n' "$url" "$p"
    if [ -n "$docroot" ]; then printf 'output = "%s%s"\n' "$docroot" "$p"; else echo 'output = "/dev/null"'; fi
  done <"$paths" >"$paths.curl"
  codes=$(curl -sS --fail --fail-early --create-dirs -K "$paths.curl" -w '%{http_code}\n') ||
    { echo "fetching the paths of $paths from $url failed" >&2; return 1; }
  [ "$(grep -c '^200$' <<<"$codes")" -eq "$n" ] || { echo "not every path of $paths came back 200 from $url" >&2; return 1; }
}

# ---- CPU accounting ----------------------------------------------------------------------------

# cpu_ticks PID...: CPU time (user + system, clock ticks) of the processes and their direct
# children: zoomwarp's threads are all in its own /proc/PID/stat, nginx's work is done by the
# workers under its master.
cpu_ticks() {
  local pid total=0 t
  for pid in "$@" $(for p in "$@"; do pgrep -P "$p" 2>/dev/null || true; done); do
    # Fields after "(comm)": state is 1, utime 12, stime 13.
    t=$(awk '{ sub(/^.*\) /, ""); print $12 + $13 }' "/proc/$pid/stat" 2>/dev/null || echo 0)
    total=$((total + t))
  done
  echo "$total"
}

# Busy CPU time of the whole machine (clock ticks: user, nice, system, irq, softirq, steal). Minus
# the server's and wrk's own, it shows how much else ran during a run: on a small machine any other
# load (a compiler, another benchmark) lowers every server's figures, not always by the same amount.
machine_busy_ticks() { awk '/^cpu / { print $2 + $3 + $4 + $7 + $8 + $9; exit }' /proc/stat; }

# ---- wrk ---------------------------------------------------------------------------------------

# Writes $wrk_work_dir/paths.lua. Each wrk thread walks the whole path list (the script's first
# argument) in order, from its own starting point so that threads do not ask for the same path at
# the same moment; requests are pre-formatted in init() to keep Lua work per request small. wrk
# counts statuses >= 400 in errors.status. With WRK_CHECK_STATUS=1 in the environment the script
# also counts every answer other than 200 (3xx included) — this defines response(), which makes wrk
# keep every header and body, so it is for the runs where a request costs far more than that.
# done() prints one machine-readable line.
write_wrk_script() {
  cat >"$wrk_work_dir/paths.lua" <<'EOF'
local reqs, n, i = {}, 0, 0
local threads = {}
not_ok = 0

function setup(thread)
  thread:set("thread_index", #threads)
  table.insert(threads, thread)
end

function init(args)
  for path in io.lines(args[1]) do
    n = n + 1
    reqs[n] = wrk.format("GET", path)
  end
  i = (thread_index * 7919) % n
end

function request()
  i = i % n + 1
  return reqs[i]
end

if os.getenv("WRK_CHECK_STATUS") == "1" then
  function response(status, headers, body)
    if status ~= 200 then not_ok = not_ok + 1 end
  end
end

function done(summary, latency, requests)
  local e, bad = summary.errors, 0
  for _, t in ipairs(threads) do bad = bad + (t:get("not_ok") or 0) end
  io.write(string.format(
    "WRK_RESULT requests=%d duration_us=%d bytes=%d p50_us=%d p99_us=%d max_us=%d connect=%d read=%d write=%d status=%d timeout=%d not_ok=%d\n",
    summary.requests, summary.duration, summary.bytes, latency:percentile(50), latency:percentile(99),
    latency.max, e.connect, e.read, e.write, e.status, e.timeout, bad))
end
EOF
}

# run_wrk NAME "PID..." URL SECONDS PATHS THREADS CONNECTIONS [check]: wrk --latency against URL
# with the paths of the file PATHS; PIDs are the processes whose CPU counts as the server's. With
# `check`, answers other than 200 are counted too (WRK_CHECK_STATUS above). Sets
#   wrk_requests, wrk_rps, wrk_p50_ms, wrk_p99_ms    what wrk measured
#   srv_cores, srv_cpu_ms                            the server's CPU: cores, ms per request
#   wrk_cores, other_cores                           wrk's own CPU, everything else's
# and fails on any socket error, timeout or error status.
run_wrk() {
  local name=$1 pids=$2 url=$3 secs=$4 paths=$5 threads=$6 connections=$7 check=${8:-}
  local out="$wrk_work_dir/wrk_$name.out" ticks0 ticks1 busy0 busy1 hz line
  hz=$(getconf CLK_TCK)
  # shellcheck disable=SC2086  # pids is a list
  ticks0=$(cpu_ticks $pids); busy0=$(machine_busy_ticks)
  # bash's `time` gives wrk's own CPU use: on a small machine wrk competes with the server for it.
  local TIMEFORMAT='%U %S'
  { time WRK_CHECK_STATUS=$([ "$check" = check ] && echo 1 || echo 0) \
      wrk --latency -t "$threads" -c "$connections" -d "${secs}s" -s "$wrk_work_dir/paths.lua" \
      "$url" -- "$paths" >"$out" 2>&1; } 2>"$wrk_work_dir/wrk_time" ||
    { cat "$out" >&2; echo "wrk failed against $name" >&2; return 1; }
  # shellcheck disable=SC2086
  ticks1=$(cpu_ticks $pids); busy1=$(machine_busy_ticks)
  line=$(grep '^WRK_RESULT ' "$out") || { cat "$out" >&2; echo "no result from wrk against $name" >&2; return 1; }

  local duration_us p50 p99 connect read write status timeout not_ok
  wrk_requests=$(field requests "$line"); duration_us=$(field duration_us "$line")
  p50=$(field p50_us "$line"); p99=$(field p99_us "$line")
  connect=$(field connect "$line"); read=$(field read "$line"); write=$(field write "$line")
  status=$(field status "$line"); timeout=$(field timeout "$line"); not_ok=$(field not_ok "$line")
  [ "$wrk_requests" -gt 0 ] || { echo "wrk made no requests against $name" >&2; return 1; }
  [ "$status" -eq 0 ] || { echo "$name: $status responses with an error status (wrk: Non-2xx or 3xx)" >&2; return 1; }
  [ "$not_ok" -eq 0 ] || { echo "$name: $not_ok responses other than 200" >&2; return 1; }
  [ $((connect + read + write + timeout)) -eq 0 ] ||
    { echo "$name: socket errors: connect $connect, read $read, write $write, timeout $timeout" >&2; return 1; }

  local s=$((ticks1 - ticks0))
  wrk_rps=$(awk -v r="$wrk_requests" -v d="$duration_us" 'BEGIN { printf "%.0f", r / (d / 1e6) }')
  wrk_p50_ms=$(awk -v v="$p50" 'BEGIN { printf "%.3f", v / 1000 }')
  wrk_p99_ms=$(awk -v v="$p99" 'BEGIN { printf "%.3f", v / 1000 }')
  srv_cores=$(awk -v t="$s" -v hz="$hz" -v d="$duration_us" 'BEGIN { printf "%.2f", t / hz / (d / 1e6) }')
  srv_cpu_ms=$(awk -v t="$s" -v hz="$hz" -v r="$wrk_requests" 'BEGIN { printf "%.3f", t / hz * 1000 / r }')
  wrk_cores=$(awk -v d="$duration_us" '{ printf "%.2f", ($1 + $2) / (d / 1e6) }' "$wrk_work_dir/wrk_time")
  other_cores=$(awk -v b=$((busy1 - busy0)) -v hz="$hz" -v d="$duration_us" -v s="$srv_cores" -v w="$wrk_cores" \
    'BEGIN { o = b / hz / (d / 1e6) - s - w; printf "%.2f", o < 0 ? 0 : o }')
}

field() { sed -n "s/.* $1=\([0-9]*\).*/\1/p" <<<" $2"; }

# ---- statistics --------------------------------------------------------------------------------

# median: the median of the numbers on stdin (separated by spaces or newlines).
median() { tr ' ' '\n' | grep . | sort -g | awk '{ v[NR] = $1 } END { if (NR % 2) print v[(NR + 1) / 2]; else print (v[NR / 2] + v[NR / 2 + 1]) / 2 }'; }
ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.3f", a / b }'; }
