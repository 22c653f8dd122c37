#!/usr/bin/env bash
# The bucket store against the folder store, side by side in one run (issue 29): the same images,
# the same URL lists, `zoomwarp serve --store DIR` against `zoomwarp serve --store s3://…` on
# OpenStack Swift's s3api on loopback (tests/support/swift_s3/start.sh, as the tests use it).
#
#   ingest      `zoomwarp ingest` of a 16 MP and a 127 MP JPEG into each store (wall time, and the
#               S3 requests and bytes it made, from Swift's proxy log)
#   cold tiles  one GET of each of N Deep Zoom tiles of the 127 MP image, spread over its two
#               finest levels, on a server just started (nothing in its caches): p50, p90 and the
#               S3 requests and bytes per tile (the server's /metrics)
#   cold views  the same for N viewports (zoom 0…1, 360×640, ICAZ's model already made)
#   warm        wrk on the same tile list and on the view list once every answer was made once
#               (--response-cache 0: tiles are read from the decoded-tile and range caches, views
#               are warped and encoded each time): requests per second
#
# Everything binds to 127.0.0.1 and lives in one temp folder that the EXIT trap removes, with the
# servers and Swift. Needs python3-swift and memcached (scripts/setup.sh), vips, wrk, jq, curl.
# Run `tests/bench/s3_vs_folder.sh --help` for the options.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"      # pick_loopback_port, stop_process
# shellcheck source=../support/wrk_bench.sh
source "$repo_dir/tests/support/wrk_bench.sh"  # zoomwarp_serve, dzi_tile_paths, run_wrk

zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"
corpus="$repo_dir/../shared/corpus"
source_photo=nuthatch_tree_trunk.jpg
cold_count=100
duration=10
out_file=""

usage() {
  cat <<EOF
usage: $0 [options]

The bucket store (Swift's s3api on loopback) against the folder store: ingest of a 16 MP and a
127 MP JPEG, cold tile and viewport latency, warm throughput, S3 requests and bytes per operation.

  --zoomwarp PATH   the binary (default $zoomwarp_bin)
  --corpus DIR      the photographs (default $corpus)
  --cold N          cold tiles and cold views each (default $cold_count)
  --duration S      seconds per wrk run (default $duration)
  --out FILE        also write the report (Markdown) there
  -h, --help        this text
EOF
}

while [ $# -gt 0 ]; do
  case $1 in
    --zoomwarp) zoomwarp_bin=$2; shift 2 ;;
    --corpus) corpus=$2; shift 2 ;;
    --cold) cold_count=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --out) out_file=$2; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "unknown option $1" >&2; usage >&2; exit 2 ;;
  esac
done

die() { echo "s3_vs_folder: $*" >&2; exit 1; }
log() { echo "s3_vs_folder: $*" >&2; }
[ -x "$zoomwarp_bin" ] || die "no zoomwarp binary at $zoomwarp_bin (build it, or --zoomwarp)"
[ -f "$corpus/$source_photo" ] || die "no $corpus/$source_photo (--corpus)"
for tool in vips wrk jq curl python3; do command -v "$tool" >/dev/null || die "$tool is missing"; done

work=$(mktemp -d "${TMPDIR:-/tmp}/zoomwarp-s3-bench.XXXXXX")
wrk_work_dir=$work
server_pids=()
cleanup() {
  for pid in "${server_pids[@]}"; do stop_process "$pid" 2>/dev/null || true; done
  [ -n "${S3_DIR:-}" ] && S3_DIR=$S3_DIR "$repo_dir/tests/support/swift_s3/stop.sh" >/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# ---- the images: crops of one corpus photograph, JPEG Q90 ---------------------------------------
log "making the 16 MP and 127 MP JPEGs"
vips crop "$corpus/$source_photo" "$work/16mp.v" 540 0 4900 3264
vips jpegsave "$work/16mp.v" "$work/img16.jpg" --Q 90
vips crop "$corpus/$source_photo" "$work/crop.v" 510 287 5008 2817
vips resize "$work/crop.v" "$work/127mp.v" 3
vips jpegsave "$work/127mp.v" "$work/img127.jpg" --Q 90
rm -f "$work"/*.v

# ---- Swift on loopback, a bucket ----------------------------------------------------------------
s3_port=$(pick_loopback_port)
export S3_DIR=$work/swift
S3_PORT=$s3_port S3_WATCH_PID=$$ "$repo_dir/tests/support/swift_s3/start.sh" >"$work/swift.log" 2>&1 ||
  { cat "$work/swift.log" >&2; die "Swift did not start"; }
export AWS_ACCESS_KEY_ID=test:tester AWS_SECRET_ACCESS_KEY=testing AWS_REGION=us-east-1
export AWS_ENDPOINT_URL_S3=http://127.0.0.1:$s3_port
curl -sf -o /dev/null --aws-sigv4 aws:amz:us-east-1:s3 -H 'x-amz-content-sha256: UNSIGNED-PAYLOAD' \
  -X PUT "http://test%3Atester:testing@127.0.0.1:$s3_port/bench" || die "cannot create the bucket"
bucket_store=s3://bench/museum
folder_store=$work/folder

# Requests and bytes (in and out of Swift) in the proxy's log since line FROM: "N requests, X MB".
proxy_log=$S3_DIR/log/proxy.log
proxy_lines() { wc -l <"$proxy_log"; }
proxy_cost_since() {
  # proxy-logging's access line: … METHOD PATH PROTO STATUS REFERER AGENT TOKEN BYTES_RECVD
  # BYTES_SENT …; only the S3 API's lines, not the Swift subrequests s3api makes (/v1/AUTH_…).
  tail -n +"$(($1 + 1))" "$proxy_log" | awk '
    /^proxy-server: / {
      st = 0
      for (i = 1; i <= NF; i++) if ($i ~ /^HTTP\/1\./) { st = i; break }
      if (!st || $(st - 1) ~ /^\/v1\//) next
      n++; recv += $(st + 5) == "-" ? 0 : $(st + 5); sent += $(st + 6) == "-" ? 0 : $(st + 6)
    }
    END { printf "%d %d %d\n", n, recv, sent }'
}

timed() { local t0; t0=$(date +%s%N); "$@" >/dev/null; echo $((($(date +%s%N) - t0) / 1000000)); }

# ---- ingest -------------------------------------------------------------------------------------
declare -A ingest_ms ingest_requests ingest_bytes
for size in 16 127; do
  ingest_ms[folder_$size]=$(timed "$zoomwarp_bin" ingest "$work/img$size.jpg" --store "$folder_store" --id "img$size" --quiet)
  from=$(proxy_lines)
  ingest_ms[bucket_$size]=$(timed "$zoomwarp_bin" ingest "$work/img$size.jpg" --store "$bucket_store" --id "img$size" --quiet)
  read -r n recv _ <<<"$(proxy_cost_since "$from")"
  ingest_requests[$size]=$n ingest_bytes[$size]=$recv
  log "ingest ${size} MP: folder ${ingest_ms[folder_$size]} ms, bucket ${ingest_ms[bucket_$size]} ms ($n requests, $((recv / 1048576)) MB up)"
done

# ---- URL lists ------------------------------------------------------------------------------------
serve() {  # serve NAME STORE [FLAG...]: a fresh server; sets url_NAME and pid_NAME
  local name=$1 store=$2
  shift 2
  zoomwarp_serve "$zoomwarp_bin" "$store" "$work/$name.log" --response-cache 0 --request-timeout 60 "$@" ||
    die "$name did not start"
  server_pids+=("$zoomwarp_pid")
  printf -v "url_$name" 'http://127.0.0.1:%s' "$zoomwarp_port"
  printf -v "pid_$name" '%s' "$zoomwarp_pid"
}
serve folder "$folder_store"
dzi_tile_paths "$url_folder" img127 2 "$work/all_tiles" || die "no tile list"
shuf -n "$cold_count" --random-source=<(yes) "$work/all_tiles" >"$work/tiles"
python3 - "$cold_count" "$dzi_width" "$dzi_height" >"$work/views" <<'EOF'
import random, sys
random.seed(29)
n, w, h = (int(a) for a in sys.argv[1:4])
for _ in range(n):
    print("/v1/images/img127/viewport?zoom=%.2f&cx=%.0f&cy=%.0f&w=360&h=640"
          % (random.random(), random.uniform(0.2, 0.8) * w, random.uniform(0.2, 0.8) * h))
EOF
# ICAZ's model, made once (the first view of an image pays for it, in either store; issue 28).
curl -sf -o /dev/null "$url_folder/v1/images/img127/viewport?zoom=0&w=360&h=640" || die "first view on the folder failed"
stop_process "$pid_folder"
serve bucket "$bucket_store" --store-cache "$work/bucket-cache"
curl -sf -o /dev/null "$url_bucket/v1/images/img127/viewport?zoom=0&w=360&h=640" || die "first view on the bucket failed"
stop_process "$pid_bucket"

# Cold latency: one GET of each path on a fresh server, over one keep-alive connection.
cold_pass() {  # cold_pass URL PATHS -> "p50_ms p90_ms"
  python3 - "$1" "$2" <<'EOF'
import http.client, sys, time, urllib.parse
u = urllib.parse.urlparse(sys.argv[1])
c = http.client.HTTPConnection(u.hostname, u.port, timeout=120)
times = []
for path in open(sys.argv[2]).read().split():
    t0 = time.perf_counter()
    c.request("GET", path)
    r = c.getresponse()
    r.read()
    if r.status != 200:
        sys.exit("%s: %d" % (path, r.status))
    times.append((time.perf_counter() - t0) * 1000)
times.sort()
print("%.2f %.2f" % (times[len(times) // 2], times[len(times) * 9 // 10]))
EOF
}
store_counter() {  # store_counter URL: "requests bytes_received" of the bucket store so far
  curl -sf "$1/metrics" | awk '/^zoomwarp_store_requests_total/ { n += $2 } /^zoomwarp_store_bytes_total\{direction="received"\}/ { b = $2 } END { printf "%d %d\n", n, b }'
}

declare -A p50 p90 per_request per_bytes rps warm_requests
for what in tiles views; do
  serve folder "$folder_store"
  read -r p50[folder_$what] p90[folder_$what] <<<"$(cold_pass "$url_folder" "$work/$what")" || die "cold $what on the folder failed"
  stop_process "$pid_folder"
  rm -rf "$work/bucket-cache"
  serve bucket "$bucket_store" --store-cache "$work/bucket-cache"
  read -r n0 b0 <<<"$(store_counter "$url_bucket")"
  read -r p50[bucket_$what] p90[bucket_$what] <<<"$(cold_pass "$url_bucket" "$work/$what")" || die "cold $what on the bucket failed"
  read -r n1 b1 <<<"$(store_counter "$url_bucket")"
  per_request[$what]=$(awk -v a=$((n1 - n0)) -v c="$cold_count" 'BEGIN { printf "%.2f", a / c }')
  per_bytes[$what]=$(awk -v a=$((b1 - b0)) -v c="$cold_count" 'BEGIN { printf "%.0f", a / c }')
  stop_process "$pid_bucket"
  log "cold $what p50: folder ${p50[folder_$what]} ms, bucket ${p50[bucket_$what]} ms; ${per_request[$what]} requests, ${per_bytes[$what]} bytes each"
done

# Warm throughput: both servers up, every answer made once, then wrk on each in turn.
serve folder "$folder_store"
serve bucket "$bucket_store" --store-cache "$work/bucket-cache"
write_wrk_script
for what in tiles views; do
  for name in folder bucket; do
    url_var=url_$name pid_var=pid_$name
    fetch_paths "${!url_var}" "$work/$what" || die "warming $what on $name failed"
    [ "$name" = bucket ] && read -r n0 _ <<<"$(store_counter "$url_bucket")"
    run_wrk "${name}_$what" "${!pid_var}" "${!url_var}" "$duration" "$work/$what" 2 8 || die "wrk on $name failed"
    rps[${name}_$what]=$wrk_rps
  done
  read -r n1 _ <<<"$(store_counter "$url_bucket")"
  warm_requests[$what]=$(awk -v a=$((n1 - n0)) -v r="$wrk_requests" 'BEGIN { printf "%.4f", a / r }')
  log "warm $what: folder ${rps[folder_$what]}/s, bucket ${rps[bucket_$what]}/s"
done

ratio() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.2f", a / b }'; }
report=$(cat <<EOF
| | folder | bucket (Swift on loopback) | bucket / folder |
|---|---|---|---|
| ingest 16 MP JPEG | ${ingest_ms[folder_16]} ms | ${ingest_ms[bucket_16]} ms (${ingest_requests[16]} requests, $((ingest_bytes[16] / 1048576)) MB) | $(ratio "${ingest_ms[bucket_16]}" "${ingest_ms[folder_16]}")× |
| ingest 127 MP JPEG | ${ingest_ms[folder_127]} ms | ${ingest_ms[bucket_127]} ms (${ingest_requests[127]} requests, $((ingest_bytes[127] / 1048576)) MB) | $(ratio "${ingest_ms[bucket_127]}" "${ingest_ms[folder_127]}")× |
| cold tile p50 (p90) | ${p50[folder_tiles]} ms (${p90[folder_tiles]}) | ${p50[bucket_tiles]} ms (${p90[bucket_tiles]}) | $(ratio "${p50[bucket_tiles]}" "${p50[folder_tiles]}")× |
| cold viewport p50 (p90) | ${p50[folder_views]} ms (${p90[folder_views]}) | ${p50[bucket_views]} ms (${p90[bucket_views]}) | $(ratio "${p50[bucket_views]}" "${p50[folder_views]}")× |
| S3 requests, bytes per cold tile | | ${per_request[tiles]}, ${per_bytes[tiles]} B | |
| S3 requests, bytes per cold viewport | | ${per_request[views]}, ${per_bytes[views]} B | |
| warm tiles | ${rps[folder_tiles]}/s | ${rps[bucket_tiles]}/s (${warm_requests[tiles]} S3 requests each) | $(ratio "${rps[bucket_tiles]}" "${rps[folder_tiles]}")× |
| warm viewports | ${rps[folder_views]}/s | ${rps[bucket_views]}/s (${warm_requests[views]} S3 requests each) | $(ratio "${rps[bucket_views]}" "${rps[folder_views]}")× |

$cold_count cold tiles of the 127 MP image's two finest Deep Zoom levels and $cold_count viewports
(360×640, zoom 0–1), each on a server just started; warm: wrk -t2 -c8 ${duration} s each,
--response-cache 0. $(nproc) cores, $(date -u +%F).
EOF
)
echo "$report"
[ -z "$out_file" ] || echo "$report" >"$out_file"
