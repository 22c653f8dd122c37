#!/usr/bin/env bash
# Replicas that share a bucket and no folder (issue 29's acceptance): a real S3 server (OpenStack
# Swift + s3api on loopback, tests/support/swift_s3/), one bucket, three `zoomwarp serve
# --store s3://BUCKET/PREFIX` replicas each with its own --store-cache folder, nginx in front with
# deploy/nginx.conf (templated as in cluster_test.sh, tests/support/nginx.sh and replicas.sh).
#
#   1. ingest  two images uploaded to replica 0 are served by replicas 1 and 2 (which asked for
#              them before, and got 404) within --store-recheck-ms + 1.5 s, and every replica and
#              nginx give the same bytes for a set of Deep Zoom tiles, IIIF images and a viewport;
#   2. delete  an image uploaded to replica 0 and viewed on every replica, deleted on replica 2:
#              every replica (and nginx, past its cache) answers 404 for it and for its tile within
#              --store-recheck-ms + 1.5 s;
#   3. pause   `zoomwarp replay` through nginx (tests/load/boats_explore.jsonl, a short 'before'
#              run that must have no error, then 'during'); during it Swift's proxy is SIGSTOPped
#              for at least --pause-min s (until every replica's /readyz has said 503 "store not
#              readable"), then SIGCONTed. Asserted: the replay completes and its only errors are
#              503/504 (no connection error, no timeout); every non-2xx answer the replicas and
#              nginx logged is a 503/504, nginx's each a replica's answer passed on; probes of
#              tiles the store must be read for, straight to
#              each replica and through nginx, are a 503/504 with a JSON error store_timeout,
#              store_unavailable or deadline_exceeded and Retry-After within --request-timeout +
#              1.5 s; views through nginx during the pause likewise (when not 2xx); /healthz of
#              every replica answers 200 within 1 s throughout; /readyz turns 503 on every replica
#              and 200 again within 5 s of the resume (and zoomwarp_store_readable 0, then 1, in
#              /metrics, answered within 1 s); every non-2xx the replicas logged is counted in
#              zoomwarp_http_requests_failed_total (reasons store, deadline, negative_cache), the
#              store's failures among them; fresh tiles are served again
#              within 5 s of the resume, and no error is answered later than --failure-cache-ms
#              (5 s) + 1 s after it; an 'after' replay has no error;
#   4. nothing lost  an upload to replica 2 started during the pause either fails with a 5xx or
#              is published whole (then every replica serves its tiles, the same bytes as the
#              same image uploaded before); a fourth replica started afterwards with an empty
#              cache folder lists the images with their versions from before the pause and serves
#              the same bytes for every tile of the set as before it.
#
# Prints the phases' requests, errors by status and p50/p99, the pause's timeline, probe answers,
# the replicas' failure counters and one JSON line. Every process runs on 127.0.0.1 on ports
# picked below Linux's ephemeral range, with everything in one temp folder; the EXIT trap stops
# the replay and probes, the replicas, nginx and Swift (whose own watchdog also stops it should
# this script be SIGKILLed). ~40 s on the 2-core test VM, ~60 s while it builds (2-5 s of it
# Swift's start). The times "seen after" are upper bounds: the replicas are polled in turn. CTest
# runs it as `cluster.s3` (labels cluster, s3); `tests/cluster/s3_cluster_test.sh --help` for the
# options.
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../support/replicas.sh
source "$repo_dir/tests/support/replicas.sh"

# ---- defaults (see usage) -----------------------------------------------------------------------
before=2            # seconds of load before the pause (must have no error)
during=12           # seconds of load around the pause
after=2             # seconds of load once the store is back (must have no error)
pause_min=4         # the store stays paused at least this long…
pause_max=12        # …and until every replica's /readyz said 503, at most this long
clients=4
request_timeout=2   # the replicas' --request-timeout
recheck_ms=1000     # the replicas' --store-recheck-ms
failure_cache_ms=5000  # the server's --failure-cache-ms default: how long a view's failure is repeated
extra_serve_flags=""   # --serve-flags: appended to the replicas' flags (to show what a mechanism does)
replicas=3
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
nginx_bin=/usr/sbin/nginx
nginx_conf="$repo_dir/deploy/nginx.conf"
swift_dir="$repo_dir/tests/support/swift_s3"
keep=0
view_path="$repo_dir/tests/load/boats_explore.jsonl"
samples="$repo_dir/samples"
bucket=zoomwarp-cluster
prefix=museum

usage() {
  cat <<EOF
usage: tests/cluster/s3_cluster_test.sh [OPTIONS]

Three zoomwarp replicas on one bucket of a Swift s3api server on loopback, each with its own cache
folder and none shared, behind nginx (deploy/nginx.conf): an upload on one is served by the others
with the same bytes, a delete is seen by all within --store-recheck-ms, and the store paused
(SIGSTOP) under load gives bounded 503/504 JSON answers, liveness throughout, readiness that
fails and returns, and loses nothing. Exit codes: 0 passed, 1 failed, 77 skipped (nginx or
python3-swift/memcached missing).

options:
  --before SEC         load before the pause, no error allowed (default $before)
  --during SEC         load around the pause (default $during)
  --after SEC          load after the store is back, no error allowed (default $after)
  --pause-min SEC      the store is paused at least this long (default $pause_min)
  --pause-max SEC      and at most this long, waiting for every /readyz to fail (default $pause_max)
  --clients N          replay clients (default $clients)
  --request-timeout S  the replicas' --request-timeout; the bounds are derived from it (default $request_timeout)
  --recheck-ms MS      the replicas' --store-recheck-ms; the bounds are derived from it (default $recheck_ms)
  --serve-flags "..."  more \`zoomwarp serve\` flags for every replica, after the test's own (which
                       they override: e.g. "--request-timeout 120" shows which assertion needs
                       the small deadline; the bounds stay those of the test's own values)
  --zoomwarp PATH      zoomwarp binary (default build/bin/zoomwarp)
  --nginx PATH         nginx binary (default $nginx_bin)
  --nginx-conf PATH    nginx configuration to template (default deploy/nginx.conf)
  --keep               keep the temp folder (logs, Swift's folder and logs, replay summaries)
  -h, --help           this text

Needs: nginx (Debian nginx-light), python3-swift and memcached, curl, jq; all in scripts/setup.sh.
EOF
}

die() { echo "s3_cluster_test: FAILED: $*" >&2; exit 1; }
log() { echo "s3_cluster_test: $*" >&2; }

parse_args() {
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --before) before=${2:?--before needs a value}; shift 2 ;;
      --during) during=${2:?--during needs a value}; shift 2 ;;
      --after) after=${2:?--after needs a value}; shift 2 ;;
      --pause-min) pause_min=${2:?--pause-min needs a value}; shift 2 ;;
      --pause-max) pause_max=${2:?--pause-max needs a value}; shift 2 ;;
      --clients) clients=${2:?--clients needs a value}; shift 2 ;;
      --request-timeout) request_timeout=${2:?--request-timeout needs a value}; shift 2 ;;
      --recheck-ms) recheck_ms=${2:?--recheck-ms needs a value}; shift 2 ;;
      --serve-flags) extra_serve_flags=${2?--serve-flags needs a value}; shift 2 ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --nginx) nginx_bin=${2:?--nginx needs a value}; shift 2 ;;
      --nginx-conf) nginx_conf=${2:?--nginx-conf needs a value}; shift 2 ;;
      --keep) keep=1; shift ;;
      *) echo "s3_cluster_test: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
  done
  local n
  for n in before during after pause_min pause_max clients request_timeout recheck_ms; do
    [[ ${!n} =~ ^[0-9]+$ ]] || { echo "s3_cluster_test: --${n//_/-} must be a whole number" >&2; exit 2; }
  done
  if [ "$before" -lt 1 ] || [ "$after" -lt 1 ] || [ "$clients" -lt 1 ] || [ "$request_timeout" -lt 1 ] ||
     [ "$pause_min" -lt 4 ] || [ "$pause_max" -lt "$pause_min" ]; then
    echo "s3_cluster_test: --before, --after, --clients and --request-timeout must be at least 1, --pause-min at least 4, --pause-max at least --pause-min" >&2
    exit 2
  fi
  [ -x "$zoomwarp_bin" ] || die "zoomwarp binary not found at $zoomwarp_bin (build it first)"
  [ -f "$nginx_conf" ] || die "no nginx configuration at $nginx_conf"
  if [ ! -x "$nginx_bin" ]; then
    log "SKIPPED: nginx not found at $nginx_bin (scripts/setup.sh installs nginx-light)"; exit 77
  fi
  # What tests/support/swift_s3/start.sh needs (it installs nothing).
  if [ ! -f /usr/lib/python3/dist-packages/swift/common/middleware/s3api/s3api.py ] || [ ! -x /usr/bin/memcached ]; then
    log "SKIPPED: python3-swift (with s3api) or memcached is missing (scripts/setup.sh installs them)"; exit 77
  fi
  local tool
  for tool in curl jq sha256sum; do command -v "$tool" >/dev/null || die "$tool not found (scripts/setup.sh installs it)"; done
}

# ---- state -------------------------------------------------------------------------------------
# The replicas and nginx's ports are tests/support/replicas.sh's.
declare -a replica_pid replica_port replica_log
declare nginx_port nginx_bypass_port
work=""             # the one temp folder
nginx_pid=""
s3_dir="" s3_port="" s3_proxy_pid=""
paused=0
background=()       # the replay, probe loops and the upload: stopped first by the EXIT trap
t0=0                # the run's start (ns), for the timeline

now_ns() { date +%s%N; }
ms_since() { echo $(( ($(now_ns) - $1) / 1000000 )); }

# our_child PID: PID is a live child of this shell (not a pid reaped and reused since).
our_child() {
  local stat fields
  read -r stat 2>/dev/null <"/proc/$1/stat" || return 1
  read -r -a fields <<<"${stat##*) }"   # state, ppid, …
  [ "${fields[1]}" = $$ ] && [ "${fields[0]}" != Z ]
}

# stop_tree PID: a background subshell (a probe loop, the upload) and the command it is running:
# frozen first, so that it starts no other, then both ended. Nothing if PID is no child of ours.
stop_tree() {
  local pid=$1 children
  our_child "$pid" || return 0
  kill -STOP "$pid" 2>/dev/null || return 0
  children=$(pgrep -P "$pid" 2>/dev/null || true)
  # shellcheck disable=SC2086  # one pid a word
  [ -z "$children" ] || kill -TERM $children 2>/dev/null || true
  kill -TERM "$pid" 2>/dev/null || true
  kill -CONT "$pid" 2>/dev/null || true
  stop_process "$pid"
}

cleanup() {
  local rc=$? pid
  trap - EXIT INT TERM
  [ "$paused" -eq 0 ] || kill -CONT "$s3_proxy_pid" 2>/dev/null || true
  for pid in "${background[@]}"; do stop_tree "$pid"; done
  # The replicas drain (their --drain-delay) all at once rather than one after the other, and
  # are gone before the store is.
  for pid in "${replica_pid[@]}"; do [ -z "$pid" ] || kill -TERM "$pid" 2>/dev/null || true; done
  for pid in "${replica_pid[@]}"; do stop_process "$pid"; done
  if [ -n "$s3_dir" ] && [ -d "$s3_dir" ]; then
    S3_DIR="$s3_dir" S3_KEEP=$keep "$swift_dir/stop.sh" >/dev/null 2>&1 || true
  fi
  finish_cluster "$rc" "$keep" 20
}

# ---- Swift -------------------------------------------------------------------------------------
# A base port with it and the next four free (start.sh takes PORT … PORT+4), below the ephemeral range.
pick_s3_port() {
  local base k _
  for _ in $(seq 20); do
    base=$(pick_loopback_port) || return 1
    for k in 1 2 3 4; do
      if (exec 3<>"/dev/tcp/127.0.0.1/$((base + k))") 2>/dev/null; then continue 2; fi
    done
    echo "$base"; return 0
  done
  return 1
}

s3curl() {  # s3curl ARGS... URL-PATH: a signed request to the S3 server
  local path=${*: -1}
  curl -s --aws-sigv4 aws:amz:us-east-1:s3 -H 'x-amz-content-sha256: UNSIGNED-PAYLOAD' "${@:1:$#-1}" \
    "http://test%3Atester:testing@127.0.0.1:$s3_port$path"
}

# Starts Swift (again on other ports if another process took one of them first), tied to this
# shell by S3_WATCH_PID: its watchdog stops it when this script is gone, however it ended.
start_swift() {
  local attempt port
  for attempt in 1 2 3; do
    port=$(pick_s3_port) || die "found no five free ports for Swift"
    s3_dir="$work/s3.$attempt"
    if S3_DIR="$s3_dir" S3_PORT="$port" S3_WATCH_PID=$$ S3_KEEP=$keep "$swift_dir/start.sh" >"$work/s3-start.log" 2>&1; then
      s3_port=$port
      s3_proxy_pid=$(awk '$1 == "proxy" { print $2 }' "$s3_dir/pids")
      [ -n "$s3_proxy_pid" ] || die "no proxy pid in $s3_dir/pids"
      log "Swift: $(tail -n 1 "$work/s3-start.log") (proxy pid $s3_proxy_pid, state in $s3_dir)"
      return 0
    fi
    grep -qE "Address already in use|Could not bind" "$work/s3-start.log" || { cat "$work/s3-start.log" >&2; die "Swift did not start"; }
    log "Swift lost a port to another process; again on other ports"
  done
  die "Swift found no free ports"
}

# ---- HTTP helpers ------------------------------------------------------------------------------
status_of() {  # status_of URL [MAX_SECONDS]: the HTTP status (000 for none)
  curl -s -o /dev/null -w '%{http_code}' -m "${2:-10}" "$1" || true
}
replica_url() { echo "http://127.0.0.1:${replica_port[$1]}"; }

# The Deep Zoom tiles (several levels, computed with overlap), a IIIF tile sent as stored, a IIIF
# image, the .dzi and a viewport of image ID with LEVELS levels: what must be the same bytes
# everywhere and before and after the pause.
tile_set() {
  local id=$1 top=$(( $2 - 1 ))
  printf '%s\n' "/dzi/$id.dzi" "/dzi/${id}_files/0/0_0.jpg" "/dzi/${id}_files/8/0_0.jpg" \
    "/dzi/${id}_files/$((top - 1))/1_1.jpg" "/dzi/${id}_files/$top/3_1.jpg" \
    "/iiif/3/$id/0,0,256,256/256,/0/default.jpg" "/iiif/3/$id/full/512,/0/default.jpg" \
    "/v1/images/$id/viewport?zoom=0&w=360&h=640"
}

# fingerprints BASE_URL ID LEVELS OUT: "PATH STATUS SHA256" per path of tile_set ID into OUT
# (another image's paths written with ID replaced by IMAGE, so that two ids of one source compare).
# One curl and one sha256sum for the set: on a busy machine, process starts cost more than the
# requests. The bodies are kept next to OUT.
fingerprints() {
  local base=$1 id=$2 levels=$3 out=$4 paths=() statuses=() sums=() args=() files=() k
  mapfile -t paths < <(tile_set "$id" "$levels")
  for k in "${!paths[@]}"; do
    files+=("$out.body$k")
    args+=(-o "$out.body$k" "$base${paths[$k]}")
  done
  rm -f "${files[@]}"; touch "${files[@]}"
  mapfile -t statuses < <(curl -s -m 15 -w '%{http_code}\n' "${args[@]}" || true)
  mapfile -t sums < <(sha256sum "${files[@]}" | cut -c1-16)
  for k in "${!paths[@]}"; do echo "${paths[$k]//$id/IMAGE} ${statuses[$k]:-000} ${sums[$k]}"; done >"$out"
}

fingerprint_runs=0
# same_everywhere WHAT ID LEVELS REF NAME=BASE_URL...: the fingerprints of ID from every BASE_URL,
# fetched at once, each the same as the file REF; dies with the differences ("NAME serves other
# bytes for ID WHAT").
same_everywhere() {
  local what=$1 id=$2 levels=$3 ref=$4 pair pids=() out
  shift 4
  fingerprint_runs=$((fingerprint_runs + 1))
  for pair in "$@"; do
    fingerprints "${pair#*=}" "$id" "$levels" "$work/fp.$id.$fingerprint_runs.${pair%%=*}" &
    pids+=($!)
  done
  wait "${pids[@]}"
  for pair in "$@"; do
    out="$work/fp.$id.$fingerprint_runs.${pair%%=*}"
    if ! diff -u "$ref" "$out" >"$out.diff"; then
      cat "$out.diff" >&2
      die "${pair%%=*} serves other bytes for $id $what"
    fi
  done
}

# seen_everywhere T0 LIMIT_MS CHECK: runs CHECK I for replicas 0..N-1 in turn, every 50 ms, until
# it holds for each; seen_ms[I] is when it first held, in ms after T0 (ns): an upper bound, a round
# over the replicas taking a few hundred ms on a busy machine. Fails past LIMIT_MS.
declare -a seen_ms
seen_everywhere() {
  local t_start=$1 limit=$2 check=$3 i pending
  seen_ms=()
  while :; do
    pending=0
    for ((i = 0; i < replicas; i++)); do
      [ -z "${seen_ms[$i]:-}" ] || continue
      if "$check" "$i"; then seen_ms[$i]=$(ms_since "$t_start"); else pending=1; fi
    done
    [ "$pending" -eq 1 ] || return 0
    [ "$(ms_since "$t_start")" -le "$limit" ] || return 1
    sleep 0.05
  done
}
seen_list() { local i out=""; for ((i = 0; i < replicas; i++)); do out+="replica $i ${seen_ms[$i]:-never} ms, "; done; echo "${out%, }"; }

# first_view BASE_URL ID: the viewport of tile_set answered 200 by BASE_URL. The first view of an
# image computes its analysis in the background and is answered 503 analysis_pending past
# --request-timeout; the analysis is then kept in the bucket, and the other replicas read it. (Asked
# of every replica at once instead, each computes it, and on a busy machine all of them answer 503.)
first_view() {
  wait_until 30 test_status 200 "$1/v1/images/$2/viewport?zoom=0&w=360&h=640" ||
    die "$1 did not serve a view of $2 within 30 s"
}

upload() {  # upload PORT ID FILE: the status of POST /v1/images?id=ID; the body in work/upload.ID
  curl -s -o "$work/upload.$2" -w '%{http_code}' -m 60 -X POST --data-binary @"$3" \
    "http://127.0.0.1:$1/v1/images?id=$2" || true
}

# ---- 1. ingest on one, views on the others ------------------------------------------------------
declare -A levels version_before
serves_boats_and_pano() {
  [ "$(status_of "$(replica_url "$1")/v1/images/boats")" = 200 ] && [ "$(status_of "$(replica_url "$1")/v1/images/pano")" = 200 ]
}

ingest_and_compare() {
  local i id status ref t_ingest
  for ((i = 0; i < replicas; i++)); do
    for id in boats pano; do
      status=$(status_of "$(replica_url "$i")/v1/images/$id")
      [ "$status" = 404 ] || die "replica $i answers $status for $id before it was uploaded"
    done
  done
  for id in boats pano; do
    local file="$samples/boats_lake_sunset.jpg"
    [ "$id" = pano ] && file="$samples/pano_grossmugl_field_4to1.png"
    status=$(upload "${replica_port[0]}" "$id" "$file")
    [ "$status" = 201 ] || die "upload of $id to replica 0: $status $(head -c 300 "$work/upload.$id")"
    levels[$id]=$(jq -r .levels "$work/upload.$id")
    version_before[$id]=$(jq -r .version "$work/upload.$id")
  done
  t_ingest=$(now_ns)
  note "uploaded boats and pano to replica 0 (versions ${version_before[boats]}, ${version_before[pano]})"
  seen_everywhere "$t_ingest" $((recheck_ms + 1500)) serves_boats_and_pano ||
    die "the uploads were not served everywhere within --store-recheck-ms + 1.5 s: $(seen_list)"
  note "served by every replica after: $(seen_list)"
  ingest_seen="$(seen_list)"
  for id in boats pano; do
    # Replica 0 first: a view's first use computes the image's analysis there, and the bucket
    # keeps it for the others.
    first_view "$(replica_url 0)" "$id"
    ref="$work/fp.$id.before"
    fingerprints "$(replica_url 0)" "$id" "${levels[$id]}" "$ref"
    awk '$2 != 200 { bad = 1; print > "/dev/stderr" } END { exit bad }' "$ref" || die "replica 0 did not serve every path of $id's set"
    same_everywhere "than replica 0" "$id" "${levels[$id]}" "$ref" "replica1=$(replica_url 1)" "replica2=$(replica_url 2)" \
      "nginx=http://127.0.0.1:$nginx_port"
  done
  note "the same bytes for $(wc -l <"$work/fp.boats.before") paths of each image from every replica and through nginx"
}

# ---- 2. a delete seen everywhere -----------------------------------------------------------------
doomed_tile="/dzi/doomed_files/8/0_0.jpg"
doomed_gone() {
  local base; base=$(replica_url "$1")
  [ "$(status_of "$base/v1/images/doomed")" = 404 ] && [ "$(status_of "$base$doomed_tile")" = 404 ]
}

delete_everywhere() {
  local i status t_delete
  status=$(upload "${replica_port[0]}" doomed "$samples/pano_grossmugl_field_4to1.png")
  [ "$status" = 201 ] || die "upload of doomed to replica 0: $status"
  t_delete=$(now_ns)
  for ((i = 0; i < replicas; i++)); do  # every replica has read its version, and has its tile in cache
    wait_until $(( (recheck_ms + 1500 + 999) / 1000 )) test_status 200 "$(replica_url "$i")/v1/images/doomed" ||
      die "replica $i does not serve doomed $(ms_since "$t_delete") ms after its upload"
    status=$(status_of "$(replica_url "$i")$doomed_tile")
    [ "$status" = 200 ] || die "replica $i answers $status for $doomed_tile"
  done
  status=$(curl -s -o /dev/null -w '%{http_code}' -m 10 -X DELETE "$(replica_url 2)/v1/images/doomed" || true)
  [ "$status" = 204 ] || die "DELETE of doomed on replica 2: $status"
  t_delete=$(now_ns)
  seen_everywhere "$t_delete" $((recheck_ms + 1500)) doomed_gone ||
    die "the delete on replica 2 was not seen everywhere within --store-recheck-ms + 1.5 s: $(seen_list)"
  delete_seen="$(seen_list)"
  status=$(status_of "http://127.0.0.1:$nginx_bypass_port/v1/images/doomed")
  [ "$status" = 404 ] || die "nginx answers $status for the deleted image"
  note "deleted doomed on replica 2; 404 (image and tile) on: $delete_seen; through nginx too"
}
test_status() { [ "$(status_of "$2")" = "$1" ]; }

# ---- 3. load, and the store paused under it ------------------------------------------------------
# replay PHASE PORT ARGS...: `zoomwarp replay --json`, its summary in PHASE.json. Run in the
# background (a subshell of its own), it becomes the replay process: $! is the replay's pid.
replay() {
  local phase=$1 port=$2; shift 2
  local command=("$zoomwarp_bin" replay "$view_path" --image boats --url "http://127.0.0.1:$port"
                 --clients "$clients" --timeout $((request_timeout + 3)) --json "$@")
  if [ "$BASHPID" != $$ ]; then exec "${command[@]}" >"$work/$phase.json" 2>"$work/$phase.err"; fi
  "${command[@]}" >"$work/$phase.json" 2>"$work/$phase.err"
}

check_phase() {  # check_phase PHASE ALLOW_5XX
  local phase=$1 allow=$2 errors requests other
  jq -e . "$work/$phase.json" >/dev/null 2>&1 || { cat "$work/$phase.err" >&2; die "replay ($phase) printed no summary"; }
  requests=$(jq .requests "$work/$phase.json")
  errors=$(jq .errors "$work/$phase.json")
  [ "$requests" -gt 0 ] || die "replay ($phase) made no requests"
  if [ "$allow" -eq 0 ]; then
    [ "$errors" -eq 0 ] || die "$errors of $requests requests failed in phase '$phase': $(jq -c .errors_by_status "$work/$phase.json") $(jq -r '.first_connection_error // ""' "$work/$phase.json")"
  else
    other=$(jq -c '.errors_by_status | with_entries(select(.key != "503" and .key != "504"))' "$work/$phase.json")
    [ "$other" = "{}" ] || die "phase '$phase' had errors other than 503/504 (a connection error is a timeout past $((request_timeout + 3)) s or a cut): $other $(jq -r '.first_connection_error // ""' "$work/$phase.json")"
  fi
}

# One view straight to replica I answered 200 (its warp engine loaded: a view waits for it until
# the deadline, then 503 analysis_pending), so that 'before' is the steady state.
primed() {
  [ "$(status_of "$(replica_url "$1")/v1/images/boats/viewport?zoom=0&cx=1280&cy=800&w=480&h=360&method=icaz&format=jpg")" = 200 ]
}

failure_deltas() {  # failure_deltas BEFORE AFTER: "reason=n" of the counters that grew
  awk -F= 'NR == FNR { b[$1] = $2; next } { d = $2 - b[$1]; if (d) printf "%s=%d\n", $1, d }' <(echo "$1") <(echo "$2")
}
failed_by_reason() {  # reason=count pairs summed over the replicas
  local i
  for ((i = 0; i < replicas; i++)); do curl -s -m 5 "$(replica_url "$i")/metrics"; done |
    sed -n 's/^zoomwarp_http_requests_failed_total{.*reason="\([a-z_]*\)"} \([0-9]*\)$/\1 \2/p' |
    awk '{ s[$1] += $2 } END { for (r in s) printf "%s=%d\n", r, s[r] }' | sort
}

# health_loop I FILE: until work/stop_health exists, every 0.2 s: "MS HEALTHZ_STATUS HEALTHZ_S
# READYZ_STATUS READYZ_SAYS_STORE(0/1)", MS after t0.
health_loop() {
  local i=$1 out=$2 base hz rz says
  base=$(replica_url "$i")
  while [ ! -e "$work/stop_health" ]; do
    hz=$(curl -s -o /dev/null -w '%{http_code} %{time_total}' -m 1 "$base/healthz" || true)
    [ -n "$hz" ] || hz="000 1"
    rz=$(curl -s -o "$work/readyz.$i" -w '%{http_code}' -m 1 "$base/readyz" || true)
    says=0; grep -q "store not readable" "$work/readyz.$i" 2>/dev/null && says=1
    echo "$(ms_since "$t0") $hz ${rz:-000} $says" >>"$out"
    sleep 0.2
  done
}
readyz_failed_since() {  # readyz_failed_since I MS: replica I's /readyz said 503 "store not readable" after MS
  awk -v t="$2" '$1 >= t && $4 == 503 && $5 == 1 { found = 1 } END { exit !found }' "$work/health.$1"
}
readyz_back_since() {
  awk -v t="$2" '$1 >= t && $4 == 200 { found = 1 } END { exit !found }' "$work/health.$1"
}

# probe NAME URL: one request that the store must be read for, while it is paused: its status,
# time, Retry-After and body kept as work/probe.NAME.*
probe() {
  echo "$2" >"$work/probe.$1.url"
  curl -s -m $((request_timeout + 5)) -D "$work/probe.$1.head" -o "$work/probe.$1.body" \
    -w '%{http_code} %{time_total}\n' "$2" >"$work/probe.$1.status" 2>/dev/null || true
}
# check_answer NAME STATUS SECONDS HEADFILE BODYFILE: a 2xx, or a bounded 503/504 with a JSON error
# the store explains, and Retry-After. Prints the error code (or "ok"); dies otherwise.
allowed_codes="store_timeout store_unavailable deadline_exceeded"
check_answer() {
  local name=$1 status=$2 seconds=$3 head=$4 body=$5 code
  awk -v s="$seconds" -v b="$request_timeout" 'BEGIN { exit !(s <= b + 1.5) }' ||
    die "$name: answered $status after $seconds s, more than --request-timeout ($request_timeout s) + 1.5 s"
  if [[ $status == 2* ]]; then echo ok; return 0; fi
  [ "$status" = 503 ] || [ "$status" = 504 ] || die "$name: status $status (expected 2xx, 503 or 504): $(head -c 300 "$body")"
  code=$(jq -r '.error.code // empty' "$body" 2>/dev/null || true)
  [[ " $allowed_codes " == *" $code "* ]] || die "$name: $status with body $(head -c 300 "$body") (expected a JSON error, one of: $allowed_codes)"
  grep -qi '^retry-after: *[0-9]' "$head" || die "$name: $status without Retry-After"
  echo "$code"
}

# view_loop FILE: until work/stop_views exists, views through nginx (past its cache) that no one
# asked for before, one after another: "STATUS SECONDS CODE" per answer.
view_loop() {
  local out=$1 k=0 target answer status seconds code
  while [ ! -e "$work/stop_views" ]; do
    k=$((k + 1))
    target="/v1/images/boats/viewport?zoom=0.6&cx=$((700 + 7 * k))&cy=$((600 + 3 * k))&w=480&h=360&method=icaz&format=jpg"
    answer=$(curl -s -m $((request_timeout + 5)) -D "$work/view.head" -o "$work/view.body" -w '%{http_code} %{time_total}' \
      "http://127.0.0.1:$nginx_bypass_port$target" || true)
    read -r status seconds <<<"${answer:-000 $((request_timeout + 5))}"
    code=$(check_answer "view $target through nginx during the pause" "$status" "$seconds" "$work/view.head" "$work/view.body") ||
      { echo "FAIL $status $seconds" >>"$out"; exit 1; }
    echo "$status $seconds $code" >>"$out"
  done
}

store_readable_is() {  # store_readable_is I VALUE: replica I's /metrics, answered within 1 s, has that gauge
  curl -s -m 1 "$(replica_url "$1")/metrics" >"$work/metrics.$1" || true
  grep -qx "zoomwarp_store_readable $2" "$work/metrics.$1"
}

access_lines() { wc -l <"$work/nginx/access.log"; }
access_grew() { [ "$(access_lines)" -ge "$1" ]; }

fresh_tile_ok() {  # the store is read again: a tile no one asked for is served
  [ "$(status_of "$(replica_url "$1")/dzi/boats_files/12/$((6 + $1))_6.jpg" 3)" = 200 ]
}

pause_store() {
  local i probe_pids=() t_pause elapsed upload_pid
  rm -f "$work/stop_health" "$work/stop_views"
  for ((i = 0; i < replicas; i++)); do
    : >"$work/health.$i"
    health_loop "$i" "$work/health.$i" &
    background+=($!)
  done
  sleep 0.5   # a few answers before the pause too

  t_pause=$(now_ns); t_pause_ms=$(ms_since "$t0")
  kill -STOP "$s3_proxy_pid"; paused=1
  note "SIGSTOP Swift's proxy (pid $s3_proxy_pid)"
  # An upload started while the store hangs (pano's bytes again, to replica 2).
  ( status=$(upload "${replica_port[2]}" midpause "$samples/pano_grossmugl_field_4to1.png")
    echo "$status $(ms_since "$t0")" >"$work/midpause.status" ) &
  upload_pid=$!; background+=("$upload_pid")
  : >"$work/views"
  view_loop "$work/views" &
  background+=($!); view_pid=$!
  # Stored tiles no one has read (a ranged GET of the level file), straight to each replica and
  # through nginx: early (the image's version still trusted: the level reader waits) and after
  # --store-recheck-ms (the lookup of the version waits). Early, full-resolution tiles of the
  # lower right (x >= 1536, y >= 1280), far from the path's points of interest: no view at a zoom
  # that reads level 0 comes near them, and no other request of the test reads them.
  sleep 0.3
  for ((i = 0; i < replicas; i++)); do
    probe "early.replica$i" "$(replica_url "$i")/iiif/3/boats/$((1536 + 256 * i)),1280,256,256/256,/0/default.jpg" & probe_pids+=($!)
  done
  probe early.nginx "http://127.0.0.1:$nginx_bypass_port/iiif/3/boats/2304,1280,256,256/256,/0/default.jpg" & probe_pids+=($!)
  sleep $(( (recheck_ms + 999) / 1000 ))
  for ((i = 0; i < replicas; i++)); do
    probe "late.replica$i" "$(replica_url "$i")/iiif/3/boats/$((256 * (i + 4))),0,256,256/256,/0/default.jpg" & probe_pids+=($!)
  done
  probe late.nginx "http://127.0.0.1:$nginx_bypass_port/dzi/boats_files/11/2_2.jpg" & probe_pids+=($!)
  background+=("${probe_pids[@]}")
  wait "${probe_pids[@]}"

  # Paused at least pause_min s, and until every replica's /readyz has said so.
  while :; do
    elapsed=$(ms_since "$t_pause")
    local all=1
    for ((i = 0; i < replicas; i++)); do readyz_failed_since "$i" "$t_pause_ms" || all=0; done
    if [ "$all" -eq 1 ] && [ "$elapsed" -ge $((pause_min * 1000)) ]; then break; fi
    if [ "$elapsed" -ge $((pause_max * 1000)) ]; then
      for ((i = 0; i < replicas; i++)); do
        readyz_failed_since "$i" "$t_pause_ms" || die "replica $i's /readyz did not answer 503 \"store not readable\" within $pause_max s of the pause: $(tail -n 3 "$work/health.$i" | tr '\n' ';')"
      done
    fi
    sleep 0.1
  done
  readyz_failed_ms=()
  for ((i = 0; i < replicas; i++)); do
    readyz_failed_ms[$i]=$(awk -v t="$t_pause_ms" '$1 >= t && $4 == 503 && $5 == 1 { print $1 - t; exit }' "$work/health.$i")
    store_readable_is "$i" 0 || die "replica $i: /metrics did not say zoomwarp_store_readable 0 within 1 s during the pause: $(grep store_readable "$work/metrics.$i")"
  done
  touch "$work/stop_views"
  wait "$view_pid" || die "a view through nginx during the pause was not a bounded 503/504 with a JSON error (see above)"

  kill -CONT "$s3_proxy_pid"; paused=0
  t_resume=$(now_ns); t_resume_ms=$(ms_since "$t0")
  pause_ms=$(( (t_resume - t_pause) / 1000000 ))
  note "SIGCONT Swift's proxy after $pause_ms ms; /readyz said 503 after $(IFS=/; echo "${readyz_failed_ms[*]}") ms"

  seen_everywhere "$t_resume" 5000 fresh_tile_ok || die "fresh tiles not served again within 5 s of the resume: $(seen_list)"
  recovered="$(seen_list)"
  note "fresh tiles served again after: $recovered"
  local t_limit=$(( $(now_ns) + 5000000000 ))
  for ((i = 0; i < replicas; i++)); do
    until readyz_back_since "$i" "$t_resume_ms"; do
      [ "$(now_ns)" -lt "$t_limit" ] || die "replica $i's /readyz not 200 within 5 s of the resume: $(tail -n 3 "$work/health.$i" | tr '\n' ';')"
      sleep 0.1
    done
  done
  touch "$work/stop_health"
  readyz_back_ms=()
  for ((i = 0; i < replicas; i++)); do
    readyz_back_ms[$i]=$(awk -v t="$t_resume_ms" '$1 >= t && $4 == 200 { print $1 - t; exit }' "$work/health.$i")
    store_readable_is "$i" 1 || die "replica $i: /metrics does not say zoomwarp_store_readable 1 once /readyz is 200 again: $(grep store_readable "$work/metrics.$i")"
  done
  note "/readyz 200 again after $(IFS=/; echo "${readyz_back_ms[*]}") ms"
}

# What the probes and the health loops saw, checked once the pause is over.
check_pause_answers() {
  local f name status seconds code i failed_probes=0
  probe_codes=""
  for f in "$work"/probe.*.status; do
    name=${f#"$work/probe."}; name=${name%.status}
    read -r status seconds <"$f" || true
    [ "${status:-000}" != 000 ] || die "probe $name: no answer within $((request_timeout + 5)) s (store paused: the request must end by --request-timeout)"
    if [[ $status == 2* ]]; then
      # Never read itself, but its bytes may have come with a neighbour's (the bucket is read in
      # 32 KiB blocks): then it must be the very tile the store holds.
      curl -sf -o "$work/probe.$name.after" "$(cat "$work/probe.$name.url")" || die "probe $name: not served after the resume"
      cmp -s "$work/probe.$name.body" "$work/probe.$name.after" ||
        die "probe $name: $status during the pause with other bytes than after it"
      probe_codes+="$name=$status (held) ${seconds}s, "
      continue
    fi
    code=$(check_answer "probe $name" "$status" "$seconds" "$work/probe.$name.head" "$work/probe.$name.body") || exit 1
    probe_codes+="$name=$status/$code ${seconds}s, "
    failed_probes=$((failed_probes + 1))
  done
  [ "$failed_probes" -gt 0 ] || die "every probe of a tile never read was served during the pause: $probe_codes"
  probe_codes=${probe_codes%, }
  views_summary=$(awk '{ n[$1 " " $3]++; if ($2 > m) m = $2 } END { for (k in n) printf "%s×%d, ", k, n[k]; printf "slowest %.2f s", m }' "$work/views")
  [ -s "$work/views" ] || die "no view through nginx was answered during the pause"
  # Liveness throughout: every /healthz between the pause and the resume a 200 within 1 s.
  health_summary=""
  for ((i = 0; i < replicas; i++)); do
    local n bad
    n=$(awk -v a="$t_pause_ms" -v b="$t_resume_ms" '$1 >= a && $1 <= b' "$work/health.$i" | wc -l)
    bad=$(awk -v a="$t_pause_ms" -v b="$t_resume_ms" '$1 >= a && $1 <= b && ($2 != 200 || $3 >= 1)' "$work/health.$i")
    [ -z "$bad" ] || die "replica $i's /healthz failed during the pause (ms status seconds ...): $(echo "$bad" | head -3 | tr '\n' ';')"
    [ "$n" -ge $(( pause_ms / 1000 )) ] || die "replica $i: only $n /healthz probes during the $pause_ms ms pause"
    health_summary+="replica $i $n×200 (slowest $(awk -v a="$t_pause_ms" -v b="$t_resume_ms" '$1 >= a && $1 <= b && $3 > m { m = $3 } END { printf "%.3f", m }' "$work/health.$i") s), "
  done
  health_summary=${health_summary%, }
}

# Every non-2xx answer of the load phases, as the replicas and nginx logged them: only 503 and 504,
# none later than --failure-cache-ms + 1 s after the resume.
check_logged_errors() {
  local i lines from late
  : >"$work/replica_errors"
  for ((i = 0; i < replicas; i++)); do
    from=$(( ${log_mark[$i]} + 1 ))
    tail -n +"$from" "${replica_log[$i]}" |
      jq -c --arg i "$i" 'select(.msg == "request" and (.status < 200 or .status > 299) and .target != "/readyz")
                          | {replica: $i, ts, status, target, ms}' >>"$work/replica_errors"
  done
  lines=$(jq -r 'select(.status != 503 and .status != 504) | "replica \(.replica) \(.status) \(.target)"' "$work/replica_errors")
  [ -z "$lines" ] || die "replicas answered other errors than 503/504 during the load: $(echo "$lines" | head -5 | tr '\n' ';')"
  # ts is "2026-01-02T03:04:05.678Z": seconds since the epoch, then the milliseconds
  late=$(jq -r --argjson after $(( t_resume / 1000000 + failure_cache_ms + 1000 )) \
    '((.ts[0:19] + "Z" | fromdate) * 1000 + (.ts[20:23] | tonumber)) as $t | select($t > $after) | "replica \(.replica) \(.status) \(.target) \($t - $after) ms late"' \
    "$work/replica_errors")
  [ -z "$late" ] || die "errors later than --failure-cache-ms + 1 s after the resume: $(echo "$late" | head -5 | tr '\n' ';')"
  replica_errors_by_status=$(jq -s -c 'group_by(.status) | map({key: (.[0].status | tostring), value: length}) | from_entries' "$work/replica_errors")
  last_error_ms=$(jq -s -r --argjson resume $(( t_resume / 1000000 )) \
    'map((.ts[0:19] + "Z" | fromdate) * 1000 + (.ts[20:23] | tonumber) - $resume) | max // "none"' "$work/replica_errors")
  tail -n +$(( nginx_mark + 1 )) "$work/nginx/access.log" |
    jq -c 'select(.status < 200 or .status > 299)' >"$work/nginx_errors"
  lines=$(jq -r 'select(.status != 503 and .status != 504) | "\(.status) \(.target) upstream \(.upstream_status)"' "$work/nginx_errors")
  [ -z "$lines" ] || die "nginx answered other errors than 503/504 during the load: $(echo "$lines" | head -5 | tr '\n' ';')"
  # Each one a replica's answer passed on (its JSON body), not one of nginx's own (an HTML page).
  lines=$(jq -r 'select(.upstream_status != (.status | tostring)) | "\(.status) \(.target) upstream \(.upstream_status)"' "$work/nginx_errors")
  [ -z "$lines" ] || die "nginx answered errors of its own, not a replica's: $(echo "$lines" | head -5 | tr '\n' ';')"
  nginx_errors_by_status=$(jq -s -c 'group_by(.status) | map({key: (.[0].status | tostring), value: length}) | from_entries' "$work/nginx_errors")
}

# ---- 4. nothing lost -----------------------------------------------------------------------------
# The upload made during the pause: answered 201 and then whole everywhere, or a 5xx and then
# absent everywhere or (the paused store carried out its commit later) whole everywhere.
check_midpause_upload() {
  local status at i states bases=()
  for ((i = 0; i <= replicas; i++)); do bases+=("replica$i=$(replica_url "$i")"); done
  read -r status at <"$work/midpause.status"
  midpause="$status after $(( at - t_pause_ms )) ms from the pause"
  [[ $status == 201 || $status == 5* ]] || die "the upload during the pause answered $status: $(head -c 300 "$work/upload.midpause")"
  sleep $(( (recheck_ms + 999) / 1000 ))   # a later commit is seen within --store-recheck-ms
  states=""
  for ((i = 0; i <= replicas; i++)); do states+="$(status_of "$(replica_url "$i")/v1/images/midpause") "; done
  states=${states% }
  if [ "$status" = 201 ] || [[ $states == *200* ]]; then
    [ "$states" = "$(printf '200 %.0s' $(seq 0 "$replicas") | sed 's/ $//')" ] ||
      die "the upload during the pause ($status) is not served by every replica: $states"
    first_view "$(replica_url 0)" midpause
    same_everywhere "(the upload during the pause) than pano, the same source uploaded before" midpause "${levels[pano]}" \
      "$work/fp.pano.before" "${bases[@]}"
    midpause+=", published whole: every replica serves its $(wc -l <"$work/fp.pano.before") paths, the same bytes as pano's"
  else
    [ "$states" = "$(printf '404 %.0s' $(seq 0 "$replicas") | sed 's/ $//')" ] ||
      die "the upload during the pause failed ($status) but replicas answer $states for it"
    midpause+=", not published (404 everywhere)"
  fi
}

nothing_lost() {
  local id i listed
  # A replica that has read nothing yet (an empty --store-cache): the bucket alone.
  start_replica "$replicas"
  note "replica $replicas started with an empty cache folder, not behind nginx"
  listed=$(curl -s -m 10 "$(replica_url "$replicas")/v1/images" | jq -c '[.images[] | {key: .id, value: .version}] | from_entries')
  for id in boats pano; do
    [ "$(jq -r --arg id "$id" '.[$id] // "missing"' <<<"$listed")" = "${version_before[$id]}" ] ||
      die "replica $replicas lists $id as $(jq -r --arg id "$id" '.[$id] // "missing"' <<<"$listed"), expected version ${version_before[$id]}: $listed"
  done
  [ "$(jq -r '.doomed // "gone"' <<<"$listed")" = gone ] || die "the deleted image is listed again: $listed"
  local bases=()
  for ((i = 0; i <= replicas; i++)); do bases+=("replica$i=$(replica_url "$i")"); done
  for id in boats pano; do
    same_everywhere "after the pause than before it" "$id" "${levels[$id]}" "$work/fp.$id.before" "${bases[@]}" \
      "nginx=http://127.0.0.1:$nginx_bypass_port"
  done
  check_midpause_upload
  note "nothing lost: listed with their versions, $(( 2 * $(wc -l <"$work/fp.boats.before") )) paths the same bytes from every replica, the fresh one included"
}

# ---- the run -----------------------------------------------------------------------------------
timeline=()
note() {
  local tenths=$(( ($(now_ns) - t0) / 100000000 ))
  timeline+=("$(printf '%4d.%d s  %s' $((tenths / 10)) $((tenths % 10)) "$*")")
  log "$*"
}

pcts() {  # "p50/p99 ms" of viewport zoom, viewport pan, mesh zoom, mesh pan
  jq -r '[.endpoints.viewport.zoom, .endpoints.viewport.pan, .endpoints.mesh.zoom, .endpoints.mesh.pan]
         | map("\(.p50_ms // 0 | . * 10 | round / 10)/\(.p99_ms // 0 | . * 10 | round / 10)") | join("  ")' "$1"
}

main() {
  parse_args "$@"
  t0=$(now_ns)
  work=$(mktemp -d "${TMPDIR:-/tmp}/zoomwarp-s3-cluster.XXXXXX")
  trap cleanup EXIT INT TERM

  start_swift
  s3curl -o "$work/bucket.out" -w '%{http_code}' -X PUT "/$bucket" >"$work/bucket.status" || true
  [ "$(cat "$work/bucket.status")" = 200 ] || die "could not create bucket $bucket: $(cat "$work/bucket.status") $(cat "$work/bucket.out")"
  note "Swift on 127.0.0.1:$s3_port, bucket $bucket"

  export AWS_ACCESS_KEY_ID=test:tester AWS_SECRET_ACCESS_KEY=testing AWS_REGION=us-east-1
  export AWS_ENDPOINT_URL_S3="http://127.0.0.1:$s3_port"
  replica_store="s3://$bucket/$prefix"
  replica_cache_root="$work/caches"
  drain_delay=0   # (replicas.sh's, deploy/compose.yaml's 2 s) no replica is SIGTERMed under load here
  local serve_flags=(--open-writes --request-timeout "$request_timeout" --store-recheck-ms "$recheck_ms")
  # shellcheck disable=SC2206  # --serve-flags is split into words on purpose
  [ -z "$extra_serve_flags" ] || serve_flags+=($extra_serve_flags)
  start_replicas "$replicas" "" "${serve_flags[@]}"
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_answers || die "nginx did not start"
  note "replicas on ports ${replica_port[*]} (store $replica_store, each its own cache folder in $replica_cache_root; flags ${serve_flags[*]}), nginx on $nginx_port and $nginx_bypass_port"

  ingest_and_compare
  delete_everywhere

  seen_everywhere "$(now_ns)" 30000 primed || die "views not served by every replica within 30 s: $(seen_list)"
  note "a view served by every replica (warp engines loaded) after: $(seen_list)"
  replay before "$nginx_bypass_port" --duration "$before" || die "replay (before) could not run: $(cat "$work/before.err")"
  check_phase before 0

  # Where the load phases start in the logs, and the failure counters then.
  local i
  log_mark=()
  for ((i = 0; i < replicas; i++)); do log_mark[$i]=$(wc -l <"${replica_log[$i]}"); done
  nginx_mark=$(access_lines)
  failed_before=$(failed_by_reason)

  local replay_pid status=0 lines
  replay during "$nginx_bypass_port" --duration "$during" &
  replay_pid=$!; background+=("$replay_pid")
  lines=$(access_lines)
  wait_until 10 access_grew $((lines + 100)) || die "no traffic through nginx"
  pause_store
  wait "$replay_pid" || status=$?
  [ "$status" -eq 0 ] || die "replay (during) could not run: $(cat "$work/during.err")"
  check_phase during 1
  # A view that failed in the pause may be answered with that failure for --failure-cache-ms
  # after it: 'after' (no error allowed) starts past that.
  local wait_ms=$(( failure_cache_ms + 1000 - $(ms_since "$t_resume") ))
  [ "$wait_ms" -le 0 ] || sleep "$(awk -v ms="$wait_ms" 'BEGIN { printf "%.1f", ms / 1000 }')"
  wait "${background[@]}" 2>/dev/null || true   # the health loops, the upload
  check_pause_answers

  replay after "$nginx_bypass_port" --duration "$after" || die "replay (after) could not run: $(cat "$work/after.err")"
  check_phase after 0
  check_logged_errors
  # Errors counted: every non-2xx the replicas logged is in zoomwarp_http_requests_failed_total,
  # for the store (or its deadline, or a repeat of either), and the store's failures are there.
  local failed_delta counted logged
  failed_delta=$(failure_deltas "$failed_before" "$(failed_by_reason)")
  failed_summary=$(echo "$failed_delta" | tr '\n' ' ')
  counted=$(awk -F= '{ s += $2 } END { print s + 0 }' <<<"$failed_delta")
  logged=$(wc -l <"$work/replica_errors")
  [ "$counted" -eq "$logged" ] ||
    die "the replicas logged $logged non-2xx answers during the load, their zoomwarp_http_requests_failed_total grew by $counted ($failed_summary)"
  ! grep -qvE '^(store|deadline|negative_cache)=' <<<"$failed_delta" ||
    die "failures for other reasons than the store during the load: $failed_summary"
  store_failed=$(sed -n 's/^store=//p' <<<"$failed_delta")
  [ "${store_failed:-0}" -gt 0 ] || die "the replicas counted no store failure (zoomwarp_http_requests_failed_total{reason=\"store\"}) during the pause"

  nothing_lost

  # ---- report ----
  local phase
  echo
  echo "three replicas on s3://$bucket/$prefix (Swift s3api on loopback, no shared folder) behind nginx ($nginx_conf), $clients replay clients over $(basename "$view_path"):"
  for i in "${timeline[@]}"; do echo "  $i"; done
  echo
  printf '%-8s %9s %7s %-22s %9s   %s\n' phase requests errors "errors by status" "req/s" "p50/p99 ms: viewport zoom  pan  mesh zoom  pan"
  for phase in before during after; do
    printf '%-8s %9d %7d %-22s %9.1f   %s\n' "$phase" "$(jq .requests "$work/$phase.json")" "$(jq .errors "$work/$phase.json")" \
      "$(jq -c .errors_by_status "$work/$phase.json")" "$(jq .requests_per_second "$work/$phase.json")" "$(pcts "$work/$phase.json")"
  done
  echo
  echo "pause: $pause_ms ms; /readyz 503 after $(IFS=/; echo "${readyz_failed_ms[*]}") ms, 200 again $(IFS=/; echo "${readyz_back_ms[*]}") ms after the resume"
  echo "/healthz during the pause: $health_summary"
  echo "probes during the pause: $probe_codes"
  echo "views through nginx during the pause (status code × n): $views_summary"
  echo "non-2xx answers logged from 'during' to 'after': replicas $replica_errors_by_status, nginx $nginx_errors_by_status; the last $last_error_ms ms after the resume"
  echo "replicas' zoomwarp_http_requests_failed_total, growth from 'during' to 'after' by reason: $failed_summary(= the non-2xx they logged)"
  echo "fresh tiles served again after the resume: $recovered"
  echo "upload during the pause: $midpause"
  echo "ingest seen: $ingest_seen; delete seen: $delete_seen"
  echo "wall time: $(( $(ms_since "$t0") / 1000 )) s"
  jq -cn --slurpfile before "$work/before.json" --slurpfile during "$work/during.json" --slurpfile after "$work/after.json" \
    --argjson pause_ms "$pause_ms" --argjson store_failed "$store_failed" --argjson replica_errors "$replica_errors_by_status" \
    --argjson nginx_errors "$nginx_errors_by_status" --arg midpause "$midpause" \
    '{pause_ms: $pause_ms, store_failures_counted: $store_failed, replica_errors: $replica_errors, nginx_errors: $nginx_errors,
      midpause_upload: $midpause,
      phases: ({before: $before[0], during: $during[0], after: $after[0]}
               | map_values({requests, errors, errors_by_status,
                             p99_ms: (.endpoints | map_values(map_values(.p99_ms)))}))}'
  log "passed"
}

main "$@"
