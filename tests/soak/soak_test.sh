#!/usr/bin/env bash
# Soak: a long run of everything at once against three `zoomwarp serve` replicas that share one
# store behind nginx with deploy/nginx.conf (templated as in tests/cluster, tests/support/nginx.sh).
# For --minutes N (default 30), concurrently:
#   replay    `zoomwarp replay` of the view paths in tests/load/*.jsonl (mesh + viewport, icaz and
#             traditional in turn) with a few clients, through nginx without cache lookups
#   uploader  uploads the samples/ images and small synthetic ones (oiiotool; tiny and extreme
#             aspects unless --no-tiny) under fixed ids, re-uploading each, and views every upload
#   editor    PUT /lines and PATCH /significance with If-Match on its own images, recording every
#             acknowledged edit (version, ETag, the lines it set)
#   deleter   uploads, views, deletes and re-uploads its own ids
#   slow      clients straight to a replica: headers sent a byte at a time, an upload whose body
#             stalls, a large viewport read at 1 KiB/s
#   sampler   every replica's RSS (VmRSS) every 10 s into rss.csv
# and in this shell the fault injector: every ~5 minutes (a third of the run when shorter)
# SIGKILL a replica and restart it a few seconds later, once a SIGTERM drain and restart instead;
# it also notices replicas that died on their own (crashes), records and restarts them.
#
# At the end it checks and prints: lost edits (every replica must return, for every edited image,
# the version of the last acknowledged edit and the lines of the last acknowledged PUT), crashes
# (replicas that died unasked, a SIGTERM that did not exit 0, "terminate called", "Segmentation
# fault" or "Aborted" in a replica's log), requests by status from nginx's access log (5xx fail the run
# unless they are 502/504 inside a fault window), the workers' unexpected answers, replay p50/p99,
# and the RSS plateau per replica: the medians of the first, middle and last third of the run and
# the growth from the middle to the last third, which fails the run above --rss-growth (a leak).
# Then one JSON line. Exit codes: 0 passed, 1 failed, 2 usage, 77 skipped (nginx missing).
#
# Everything runs on 127.0.0.1 (ports below the ephemeral range, so a replica restarts on its
# port) with everything in one temp folder; the EXIT trap stops every process this script started.
# CTest runs it as `soak.mixed` (label soak, not in scripts/test.sh): ctest --test-dir build -L soak
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../support/replicas.sh
source "$repo_dir/tests/support/replicas.sh"

# nginx's access log times are local time; UTC makes them comparable with `date -u` (nginx keeps TZ).
export TZ=UTC

# ---- defaults (see usage) -----------------------------------------------------------------------
minutes=30
clients=3              # replay clients
fault_every=300        # seconds between faults (at most a third of the run)
down=4                 # seconds a SIGKILLed replica stays down
settle=10              # seconds after a restart that still belong to the fault window
rss_growth=1.5         # largest allowed RSS growth from the middle to the last third
tiny=1                 # upload the tiny and extreme-aspect synthetic images
replicas=3
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
nginx_bin=/usr/sbin/nginx
nginx_conf="$repo_dir/deploy/nginx.conf"
keep=0

# The view paths and the images they explore (tests/load/README.md).
declare -A replay_images=(
  [boats_explore]=boats_lake_sunset
  [interior_explore]=interior_wine_djembe_tall
  [pano_explore]=pano_grossmugl_field_4to1
)

usage() {
  cat <<EOF
usage: tests/soak/soak_test.sh [OPTIONS]

Three zoomwarp replicas sharing one store behind nginx (deploy/nginx.conf) under replayed view
paths, uploads, edits, deletes and slow clients, with a replica SIGKILLed every ~5 minutes and once
SIGTERMed. Fails on a lost edit, a crash, a 5xx outside the fault windows, an unexpected answer to
an upload, edit or delete, or RSS growing more than --rss-growth from the middle to the last third.

options:
  --minutes N         length of the run (default $minutes)
  --clients N         replay clients (default $clients)
  --fault-every SEC   seconds between faults, capped at a third of the run (default $fault_every)
  --down SEC          how long a SIGKILLed replica stays down (default $down)
  --rss-growth R      largest allowed RSS ratio last third / middle third (default $rss_growth)
  --no-tiny           no tiny or extreme-aspect synthetic uploads (16x16, 3000x109, ...)
  --zoomwarp PATH     zoomwarp binary (default build/bin/zoomwarp)
  --nginx PATH        nginx binary (default $nginx_bin)
  --nginx-conf PATH   nginx configuration to template (default deploy/nginx.conf)
  --keep              keep the temp folder (logs, CSVs, replay summaries)
  -h, --help          this text

Needs: nginx (Debian nginx-light), curl, jq, oiiotool; all of them in scripts/setup.sh.
EOF
}

die() { echo "soak_test: FAILED: $*" >&2; exit 1; }
log() { echo "soak_test: $(date -u +%H:%M:%S) $*" >&2; }

parse_args() {
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --minutes) minutes=${2:?--minutes needs a value}; shift 2 ;;
      --clients) clients=${2:?--clients needs a value}; shift 2 ;;
      --fault-every) fault_every=${2:?--fault-every needs a value}; shift 2 ;;
      --down) down=${2:?--down needs a value}; shift 2 ;;
      --rss-growth) rss_growth=${2:?--rss-growth needs a value}; shift 2 ;;
      --no-tiny) tiny=0; shift ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --nginx) nginx_bin=${2:?--nginx needs a value}; shift 2 ;;
      --nginx-conf) nginx_conf=${2:?--nginx-conf needs a value}; shift 2 ;;
      --keep) keep=1; shift ;;
      *) echo "soak_test: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
  done
  local n
  for n in minutes clients fault_every down; do
    [[ ${!n} =~ ^[0-9]+$ ]] && [ "${!n}" -ge 1 ] || { echo "soak_test: --${n//_/-} must be a whole number >= 1" >&2; exit 2; }
  done
  [[ $rss_growth =~ ^[0-9]+(\.[0-9]+)?$ ]] || { echo "soak_test: --rss-growth must be a number" >&2; exit 2; }
  [ -x "$zoomwarp_bin" ] || die "zoomwarp binary not found at $zoomwarp_bin (build it first)"
  [ -f "$nginx_conf" ] || die "no nginx configuration at $nginx_conf"
  if [ ! -x "$nginx_bin" ]; then
    log "SKIPPED: nginx not found at $nginx_bin (scripts/setup.sh installs nginx-light)"; exit 77
  fi
  local tool
  for tool in curl jq oiiotool; do command -v "$tool" >/dev/null || die "$tool not found (scripts/setup.sh installs it)"; done
}

# ---- process control ---------------------------------------------------------------------------
# The replicas and nginx's ports (nginx_bypass_port for replay: every view reaches a replica)
# are tests/support/replicas.sh's. (A declare without a value keeps them, and tells shellcheck,
# which does not follow `source` without -x, that they exist.)
declare -a replica_pid replica_port replica_log
declare nginx_port nginx_bypass_port
work=""                  # the one temp folder
soak_key=""              # the curator key of the writes (start_cluster)
declare -a worker_pid
nginx_pid=""
t0=0                     # start of the load, epoch seconds
deadline=0               # end of the load, epoch seconds

# A worker is a background subshell running curl or zoomwarp replay: stop it, then its children
# (bash does not pass the signal on, and a child would finish its current request otherwise).
stop_worker() {
  local pid=$1 children=()
  mapfile -t children < <(pgrep -P "$pid" 2>/dev/null || true)
  stop_process "$pid"
  [ "${#children[@]}" -eq 0 ] || kill -TERM "${children[@]}" 2>/dev/null || true
}

# The workers, then nginx and the replicas (tests/support/replicas.sh); exits.
cleanup() {
  local rc=$? i
  trap - EXIT INT TERM
  for i in "${!worker_pid[@]}"; do stop_worker "${worker_pid[$i]}"; done
  finish_cluster "$rc" "$keep" 10
}

now() { date +%s; }
gone() { ! kill -0 "$1" 2>/dev/null; }
running() { [ "$(now)" -lt "$deadline" ]; }

# ---- replicas and nginx ------------------------------------------------------------------------
# The replicas (tests/support/replicas.sh) run with the server's defaults but for the address,
# port, store, deploy/compose.yaml's drain delay, no request log lines (nginx's access log has
# every request; a line per request would cost CPU and ~250 MB per replica over 30 minutes) and
# caches a quarter of their default size, so that they are full well within the first third of
# the run and RSS growth after that means a leak: see start_cluster.
# Writes carry a curator key (--keys), as they would in a deployment: through nginx, which passes
# Authorization on.
start_cluster() {
  soak_key=$(head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n')
  printf 'soak curator %s\n' "$soak_key" >"$work/keys"
  start_replicas "$replicas" publish_replica --keys "$work/keys" \
    --log-requests 0 --tile-cache 64M --response-cache 64M --warp-cache 64M
  start_nginx
}

# publish_replica I: replica I's pid and port in pids/I, for the sampler and the slow clients.
publish_replica() { echo "${replica_pid[$1]} ${replica_port[$1]}" >"$work/pids/$1"; }

start_nginx() {
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_answers || die "nginx did not start"
  log "nginx (pid $nginx_pid) on 127.0.0.1:$nginx_port, without cache lookups on 127.0.0.1:$nginx_bypass_port"
}

# ---- the workers' common parts -----------------------------------------------------------------
# event WORKER KIND DETAIL: one line in events.tsv. KIND "unexpected" is an answer the worker did
# not expect (a failure unless it lies in a fault window); the others are counts for the report.
event() { printf '%s\t%s\t%s\t%s\n' "$(now)" "$1" "$2" "${*:3}" >>"$work/events.tsv"; }

# http WORKER METHOD URL [CURL ARGS...]: one request; prints the status (000: no answer), keeps the
# body in $work/WORKER.body and the headers in $work/WORKER.headers. Writes send the curator key.
http() {
  local worker=$1 method=$2 url=$3 auth=(); shift 3
  [ "$method" = GET ] || auth=(-H "Authorization: Bearer $soak_key")
  curl -s -X "$method" --max-time 120 -o "$work/$worker.body" -D "$work/$worker.headers" \
    -w '%{http_code}' "${auth[@]}" "$@" "$url" || true
}

header_of() { sed -n "s/^$2: *//Ip" "$work/$1.headers" | tr -d '\r' | tail -n 1; }

# expect WORKER STATUS WHAT ALLOWED...: records an unexpected answer unless STATUS is ALLOWED.
expect() {
  local worker=$1 status=$2 what=$3; shift 3
  [[ " $* " == *" $status "* ]] && return 0
  event "$worker" unexpected "$what -> $status $(head -c 300 "$work/$worker.body" 2>/dev/null | tr '\n\t' '  ')"
  return 1
}

upload() {  # upload WORKER FILE ID: prints the status
  http "$1" POST "http://127.0.0.1:$nginx_port/v1/images?id=$3" --data-binary "@$2" \
    -H 'Content-Type: application/octet-stream'
}

# view WORKER ID: the warped views and the significance map of a fresh upload, through the cache
# (the first request of each is a miss that reaches a replica).
view() {
  local worker=$1 id=$2 q status
  for q in "viewport?zoom=0&w=480&h=360" "mesh?zoom=0.5&w=360&h=640" "viewport?zoom=1&w=640&h=640" "significance.png"; do
    status=$(http "$worker" GET "http://127.0.0.1:$nginx_port/v1/images/$id/$q")
    expect "$worker" "$status" "GET $id/$q" 200 && event "$worker" view "$id/$q"
  done
}

# ---- (a) replay --------------------------------------------------------------------------------
# The view paths in turn, icaz then traditional, until the end; each run lasts a minute, or a sixth
# of a shorter soak (so that it plays every path and method).
replayer() {
  local run=0 path name method secs length=$(( (deadline - t0) / 6 ))
  [ "$length" -le 60 ] || length=60
  while running; do
    for path in "$repo_dir"/tests/load/*.jsonl; do
      name=$(basename "$path" .jsonl)
      for method in icaz traditional; do
        secs=$(( deadline - $(now) )); [ "$secs" -le "$length" ] || secs=$length
        [ "$secs" -ge 1 ] || return 0
        run=$((run + 1))
        "$zoomwarp_bin" replay "$path" --image "${replay_images[$name]}" --method "$method" \
          --url "http://127.0.0.1:$nginx_bypass_port" --clients "$clients" --duration "$secs" --json \
          >"$work/replay/$run.json" 2>"$work/replay/$run.err" || event replay unexpected "replay $name $method exited $?"
      done
    done
  done
}

# ---- (b) uploader ------------------------------------------------------------------------------
make_synthetic_images() {
  local size sizes=(256x256 1200x300)
  [ "$tiny" -eq 0 ] || sizes+=(16x16 64x64 100x100 3000x109 109x3000 2x2000)
  for size in "${sizes[@]}"; do
    oiiotool --pattern checker:width=7:height=5 "$size" 3 -o "$work/images/synth_$size.png" >/dev/null ||
      die "oiiotool could not make a $size image"
  done
}

uploader() {
  local file id status
  while running; do
    for file in "$repo_dir"/samples/*.{jpg,png} "$work"/images/synth_*.png; do
      running || return 0
      id="up_$(basename "${file%.*}")"
      status=$(upload uploader "$file" "$id")
      expect uploader "$status" "POST $id" 201 && { event uploader upload "$id"; view uploader "$id"; }
      sleep 2
    done
  done
}

# ---- (c) editor --------------------------------------------------------------------------------
# edits.tsv: one line per acknowledged edit: time, id, kind (lines, significance, readback), the
# version and ETag it returned, and the lines the image has after it (compact JSON).
editor_ids=(edit_boats edit_square)
declare -A edit_etag edit_lines edit_w edit_h

# random_lines ID: 0 to 4 lines inside the image, as the body of PUT /lines. The end's x differs
# from the start's, so that no line is shorter than 1 px (a 400); 4 lines stay far inside the
# limits on their number and total length (warp/core/limits.h).
random_lines() {
  local id=$1 n i x0 lines=() w=${edit_w[$1]} h=${edit_h[$1]}
  n=$(( RANDOM % 5 ))
  for ((i = 0; i < n; i++)); do
    x0=$(( RANDOM % w ))
    lines+=("[$x0,$((RANDOM % h)),$(( (x0 + 1 + RANDOM % (w - 1)) % w )),$((RANDOM % h))]")
  done
  local IFS=,
  echo "{\"lines\":[${lines[*]}]}"
}

random_regions() {  # one rectangle with a random weight, as the body of PATCH /significance
  local id=$1 x y
  x=$(( RANDOM % (edit_w[$id] / 2) )); y=$(( RANDOM % (edit_h[$id] / 2) ))
  echo "{\"regions\":[{\"rect\":[$x,$y,$((edit_w[$id] / 4 + 1)),$((edit_h[$id] / 4 + 1))],\"weight\":0.$((RANDOM % 10))}]}"
}

record_edit() {  # record_edit ID KIND: the answer in editor.body/headers is an acknowledged edit
  local id=$1 kind=$2
  edit_etag[$id]=$(header_of editor ETag)
  printf '%s\t%s\t%s\t%s\t%s\t%s\n' "$(now)" "$id" "$kind" "$(jq -r .version "$work/editor.body")" \
    "${edit_etag[$id]}" "${edit_lines[$id]}" >>"$work/edits.tsv"
}

# After an answer that leaves open whether the edit was applied (no answer, 502, 504), or a 409 or
# 412 (nothing else edits these images, so an earlier edit was applied unacknowledged, e.g. a PUT
# that nginx retried on another replica after the first one applied it and died): read the image
# back and record what it is now, so that the final check knows what to expect.
editor_resync() {
  local id=$1 status
  status=$(http editor GET "http://127.0.0.1:$nginx_port/v1/images/$id/lines")
  [ "$status" = 200 ] || return 1
  edit_lines[$id]=$(jq -c . "$work/editor.body")
  status=$(http editor GET "http://127.0.0.1:$nginx_port/v1/images/$id")
  [ "$status" = 200 ] || return 1
  record_edit "$id" readback
}

editor_setup() {
  local id file status
  for id in "${editor_ids[@]}"; do
    case "$id" in
      edit_boats) file="$repo_dir/samples/boats_lake_sunset.jpg" ;;
      *) file="$work/images/synth_256x256.png" ;;
    esac
    status=$(upload editor "$file" "$id")
    [ "$status" = 201 ] || die "could not upload $id for the editor: $status $(cat "$work/editor.body")"
    edit_w[$id]=$(jq .width "$work/editor.body"); edit_h[$id]=$(jq .height "$work/editor.body")
    editor_resync "$id" || die "could not read $id back after its upload"
  done
}

# A third of the edits are significance edits, at most 512 per image: the server keeps the regions
# of all edits and refuses more than 1024 in all (warp/core/limits.h kMaxStoredRegions).
editor() {
  local id body status kind
  declare -A patches
  while running; do
    for id in "${editor_ids[@]}"; do
      running || return 0
      if [ $(( RANDOM % 3 )) -eq 0 ] && [ "${patches[$id]:-0}" -lt 512 ]; then
        patches[$id]=$(( ${patches[$id]:-0} + 1 ))
        kind=significance; body=$(random_regions "$id")
        status=$(http editor PATCH "http://127.0.0.1:$nginx_port/v1/images/$id/significance" \
          -H "If-Match: ${edit_etag[$id]}" -H 'Content-Type: application/json' --data-binary "$body")
      else
        kind=lines; body=$(random_lines "$id")
        status=$(http editor PUT "http://127.0.0.1:$nginx_port/v1/images/$id/lines" \
          -H "If-Match: ${edit_etag[$id]}" -H 'Content-Type: application/json' --data-binary "$body")
      fi
      case "$status" in
        200)
          [ "$kind" = significance ] || edit_lines[$id]=$(jq -c . <<<"$body")
          record_edit "$id" "$kind"; event editor "$kind" "$id" ;;
        000|409|412|502|503|504)
          event editor unexpected "$kind $id -> $status (resynced)"
          wait_until 30 editor_resync "$id" || event editor unexpected "cannot read $id back" ;;
        *)
          expect editor "$status" "$kind $id" 200 || true ;;
      esac
      sleep 1
    done
  done
}

# ---- (d) deleter -------------------------------------------------------------------------------
deleter() {
  local id status k=0
  while running; do
    id="del_$((k % 3))"; k=$((k + 1))
    status=$(upload deleter "$work/images/synth_256x256.png" "$id")
    if expect deleter "$status" "POST $id" 201; then
      view deleter "$id"
      status=$(http deleter DELETE "http://127.0.0.1:$nginx_port/v1/images/$id")
      expect deleter "$status" "DELETE $id" 200 204 && event deleter delete "$id"
      status=$(http deleter GET "http://127.0.0.1:$nginx_port/v1/images/$id")
      expect deleter "$status" "GET deleted $id" 404 || true
    fi
    sleep 3
  done
}

# ---- (e) slow clients --------------------------------------------------------------------------
# at_most SECONDS: SECONDS, or less so that a slow client ends a few seconds after the load.
at_most() { local left=$(( deadline - $(now) + 5 )); echo $(( left < $1 ? (left > 1 ? left : 1) : $1 )); }

some_replica_port() { cut -d' ' -f2 "$work/pids/$(( RANDOM % replicas ))"; }

# A request header sent one byte every 0.2 s straight to a replica; what came back (a 200, a 408,
# a closed connection) goes to the events.
trickle_header() {
  local port request i answer
  port=$(some_replica_port)
  request=$'GET /healthz HTTP/1.1\r\nHost: soak\r\nUser-Agent: soak-slow-header\r\nConnection: close\r\n\r\n'
  if ! exec {fd}<>"/dev/tcp/127.0.0.1/$port"; then event slow refused "header trickle to $port"; return 0; fi
  for ((i = 0; i < ${#request}; i++)); do
    printf '%s' "${request:i:1}" 1>&"$fd" 2>/dev/null || break
    sleep 0.2
  done
  answer=$(timeout "$(at_most 30)" head -n 1 <&"$fd" 2>/dev/null | tr -d '\r' || true)
  exec {fd}>&-
  event slow header "${answer:-closed}"
}

# An upload that announces 10 MB, sends 64 KiB and stalls: the replica should give up on it (how
# long it took goes to the events; "no answer" when the client gave up first, after 90 s).
stalled_upload() {
  local port start answer
  port=$(some_replica_port)
  start=$(now)
  if ! exec {fd}<>"/dev/tcp/127.0.0.1/$port"; then event slow refused "stalled upload to $port"; return 0; fi
  printf 'POST /v1/images?id=stalled HTTP/1.1\r\nHost: soak\r\nAuthorization: Bearer %s\r\nContent-Type: application/octet-stream\r\nContent-Length: 10000000\r\n\r\n' "$soak_key" 1>&"$fd" 2>/dev/null || true
  head -c 65536 "$repo_dir/samples/boats_lake_sunset.jpg" 1>&"$fd" 2>/dev/null || true
  answer=$(timeout "$(at_most 90)" head -n 1 <&"$fd" 2>/dev/null | tr -d '\r' || true)
  exec {fd}>&-
  event slow stalled_upload "$(( $(now) - start )) s: ${answer:-no answer}"
}

# A large viewport of a replayed image read at 1 KiB/s straight from a replica, for at most a minute.
slow_reader() {
  local port code rc=0
  port=$(some_replica_port)
  code=$(curl -s -o /dev/null --limit-rate 1k --max-time "$(at_most 60)" -w '%{http_code}' \
    "http://127.0.0.1:$port/v1/images/boats_lake_sunset/viewport?zoom=0.5&w=1600&h=1200&format=png") || rc=$?
  event slow reader "$code, curl exit $rc"
}

slow_clients() {
  trap '' PIPE   # a replica closing a slow connection ends that client, not this worker
  while running; do
    trickle_header & trickle_header & trickle_header & stalled_upload & slow_reader &
    wait
    sleep 5
  done
}

# ---- sampler -----------------------------------------------------------------------------------
# rss.csv: time, replica, pid, VmRSS in KiB, every 10 s, of the replicas' current processes.
sampler() {
  local i pid _
  echo "t,replica,pid,rss_kb" >"$work/rss.csv"
  while running; do
    for ((i = 0; i < replicas; i++)); do
      read -r pid _ <"$work/pids/$i"
      awk -v t="$(now)" -v i="$i" -v pid="$pid" '/^VmRSS:/ { print t "," i "," pid "," $2 }' \
        "/proc/$pid/status" 2>/dev/null >>"$work/rss.csv" || true
    done
    sleep 10
  done
}

# ---- (f) faults, and crashes -------------------------------------------------------------------
# faults.tsv: kind, replica, window start, window end (epoch seconds); crashes.tsv: time, replica,
# pid, exit status, log file.
fault_window() { printf '%s\t%s\t%s\t%s\n' "$1" "$2" "$3" "$(( $(now) + settle ))" >>"$work/faults.tsv"; }

# A replica that died while nobody was stopping it crashed: record it and restart it.
check_replicas() {
  local i status
  for ((i = 0; i < replicas; i++)); do
    kill -0 "${replica_pid[$i]}" 2>/dev/null && continue
    status=0; wait "${replica_pid[$i]}" 2>/dev/null || status=$?
    printf '%s\t%s\t%s\t%s\t%s\n' "$(now)" "$i" "${replica_pid[$i]}" "$status" "${replica_log[$i]}" >>"$work/crashes.tsv"
    log "CRASH: replica $i (pid ${replica_pid[$i]}) exited $status unasked; restarting it"
    fault_window crash "$i" $(( $(now) - 2 ))   # the requests that met the crash came just before
    start_replica "$i"
  done
}

kill_replica() {
  local i=$1 start status
  start=$(now)
  log "fault: SIGKILL replica $i (pid ${replica_pid[$i]})"
  kill -KILL "${replica_pid[$i]}"
  status=0; { wait "${replica_pid[$i]}"; } 2>/dev/null || status=$?   # (no "Killed" line from bash)
  [ "$status" -eq 137 ] || record_crash_at_stop "$i" "$status"
  sleep "$down"
  start_replica "$i"
  fault_window sigkill "$i" "$start"
}

drain_replica() {
  local i=$1 start status
  start=$(now)
  log "fault: SIGTERM replica $i (pid ${replica_pid[$i]}), restart once it has drained"
  kill -TERM "${replica_pid[$i]}"
  status=0; wait "${replica_pid[$i]}" || status=$?
  [ "$status" -eq 0 ] || record_crash_at_stop "$i" "$status"
  log "replica $i exited $status after $(( $(now) - start )) s"
  start_replica "$i"
  fault_window sigterm "$i" "$start"
}

record_crash_at_stop() {
  printf '%s\t%s\t%s\t%s\t%s\n' "$(now)" "$1" "${replica_pid[$1]}" "$2" "${replica_log[$1]}" >>"$work/crashes.tsv"
  log "CRASH: replica $1 (pid ${replica_pid[$1]}) exited $2 when stopped"
}

# Faults every fault_every seconds (at most a third of the run, so that a short run has some),
# on replicas 0 and 1 in turn: replica 2 runs undisturbed, the cleanest witness of a leak. The
# middle fault is the SIGTERM drain.
inject_faults_until_the_end() {
  local every=$fault_every total=$(( deadline - t0 )) n k=1 next
  [ "$every" -le $(( total / 3 )) ] || every=$(( total / 3 ))
  [ "$every" -ge 1 ] || every=1
  n=$(( (total - 1) / every ))
  next=$(( t0 + every ))
  log "$n faults, every $every s"
  while running; do
    check_replicas
    if [ "$k" -le "$n" ] && [ "$(now)" -ge "$next" ]; then
      if [ "$k" -eq $(( (n + 1) / 2 )) ]; then drain_replica $(( (k - 1) % 2 )); else kill_replica $(( (k - 1) % 2 )); fi
      k=$((k + 1)); next=$(( t0 + k * every ))
    fi
    sleep 1
  done
}

# ---- the checks --------------------------------------------------------------------------------
# Lines as compact JSON numbers (12.0 and 12 alike), whatever the server's number formatting.
canonical_lines() { jq -c '.lines | map(map(. * 1))'; }

# lost_edits: for every edited image, every replica must answer the version of the last
# acknowledged edit and the lines of the last acknowledged PUT (or read-back). Prints the count.
lost_edits() {
  local id i port version lines expected_version expected_lines lost=0
  for id in "${editor_ids[@]}"; do
    expected_version=$(awk -F'\t' -v id="$id" '$2 == id { v = $4 } END { print v }' "$work/edits.tsv")
    expected_lines=$(awk -F'\t' -v id="$id" '$2 == id { l = $6 } END { print l }' "$work/edits.tsv" | canonical_lines)
    for ((i = 0; i < replicas; i++)); do
      port=${replica_port[$i]}
      version=$(curl -s --max-time 30 "http://127.0.0.1:$port/v1/images/$id" | jq -r '.version // "none"' 2>/dev/null || echo none)
      lines=$(curl -s --max-time 30 "http://127.0.0.1:$port/v1/images/$id/lines" | canonical_lines 2>/dev/null || echo none)
      if [ "$version" != "$expected_version" ] || [ "$lines" != "$expected_lines" ]; then
        lost=$((lost + 1))
        log "LOST EDIT on replica $i: $id is version $version with $lines; the last acknowledged edit made version $expected_version with $expected_lines"
      fi
    done
  done
  echo "$lost"
}

# in_fault_window EPOCH: whether EPOCH lies in a fault window (faults.tsv).
in_fault_window() {
  awk -F'\t' -v t="$1" '$3 <= t && t <= $4 { found = 1 } END { exit !found }' "$work/faults.tsv"
}

# access.tsv from nginx's access log, one line per request, streamed (30 minutes are millions of
# lines): epoch time, status, 1 if in a fault window, 1 if a replayed view, seconds it took.
access_table() {
  local ids
  ids=$(printf '%s|' "${replay_images[@]}"); ids=${ids%|}
  jq -r --slurpfile w <(awk -F'\t' '{ printf "[%s,%s]\n", $3, $4 }' "$work/faults.tsv") \
    --arg re "^/v1/images/($ids)/(mesh|viewport)\\?" '
    (.ts | sub("\\+00:00$"; "Z") | fromdateiso8601) as $t |
    [$t, .status, (if any($w[]; .[0] <= $t and $t <= .[1]) then 1 else 0 end),
     (if (.target | test($re)) then 1 else 0 end), .s] | @tsv' "$work/nginx/access.log" >"$work/access.tsv"
}

# count AWK_CONDITION: the requests in access.tsv that satisfy it ($2 status, $3 in a window).
count() { awk -F'\t' "$1 { n++ } END { print n + 0 }" "$work/access.tsv"; }

# RSS medians per replica and third: "replica first middle last growth" lines, MiB. The growth
# compares the thirds of the process alive at the end, if it was sampled in the first third (a
# process started later was still filling its caches in the middle third); otherwise "n/a".
rss_plateau() {
  local third=$(( (deadline - t0) / 3 ))
  awk -F, -v t0="$t0" -v third="$third" -v n="$replicas" '
    NR == 1 { next }
    { part = int(($1 - t0) / third); if (part > 2) part = 2; if (part < 0) part = 0
      v[$2, part, ++c[$2, part]] = $3 + 0 ; rss[$2, part, c[$2, part]] = $4 / 1024
      last_pid[$2] = $3; if (!(($2, $3) in first_t)) first_t[$2, $3] = $1 }
    function median(r, p, pid,   k, m, a, j, x) {
      m = 0
      for (k = 1; k <= c[r, p]; k++) if (pid == "" || v[r, p, k] == pid) a[++m] = rss[r, p, k]
      if (m == 0) return -1
      for (k = 2; k <= m; k++) { x = a[k]; for (j = k - 1; j >= 1 && a[j] > x; j--) a[j + 1] = a[j]; a[j + 1] = x }
      return (m % 2) ? a[(m + 1) / 2] : (a[m / 2] + a[m / 2 + 1]) / 2
    }
    END {
      for (r = 0; r < n; r++) {
        f = median(r, 0, ""); mid = median(r, 1, ""); l = median(r, 2, "")
        ratio = "n/a"; pid = last_pid[r]
        if (first_t[r, pid] < t0 + third) {
          pm = median(r, 1, pid); pl = median(r, 2, pid)
          if (pm > 0 && pl > 0) ratio = sprintf("%.3f", pl / pm)
        }
        printf "%d %.1f %.1f %.1f %s\n", r, f, mid, l, ratio
      }
    }' "$work/rss.csv"
}

# Latency percentile P (0-100) in ms of the replayed views that nginx answered 200 ($request_time:
# whole milliseconds, so a view from a replica's response cache takes 0).
replay_percentile() {
  awk -F'\t' '$4 == 1 && $2 == 200 { print $5 }' "$work/access.tsv" | sort -g |
    awk -v p="$1" '{ v[NR] = $1 } END { if (NR == 0) print "null"; else { i = int((NR - 1) * p / 100) + 1; printf "%.1f", v[i] * 1000 } }'
}

# Stops the replicas (SIGTERM; a non-zero exit is a crash, so is a drain over a minute) and nginx.
stop_everything() {
  local i status
  for ((i = 0; i < replicas; i++)); do
    kill -TERM "${replica_pid[$i]}" 2>/dev/null || true
  done
  for ((i = 0; i < replicas; i++)); do
    wait_until 60 gone "${replica_pid[$i]}" || kill -KILL "${replica_pid[$i]}" 2>/dev/null || true
    status=0; wait "${replica_pid[$i]}" || status=$?
    [ "$status" -eq 0 ] || record_crash_at_stop "$i" "$status"
    replica_pid[$i]=""
  done
  stop_process "$nginx_pid"; nginx_pid=""
}

report_and_check() {
  local lost crashes log_crashes requests s5xx_out s5xx_in unexpected_out unexpected_in p50 p99
  local by_status failures=() rss_lines r f mid l ratio rss_json="" leak=0
  lost=$(lost_edits)
  stop_everything

  crashes=$(wc -l <"$work/crashes.tsv")
  log_crashes=$(cat "$work"/replica*.log | grep -cE 'terminate called|Segmentation fault|Aborted' || true)
  access_table
  requests=$(wc -l <"$work/access.tsv")
  by_status=$(cut -f2 "$work/access.tsv" | sort -n | uniq -c | awk '{ printf "%s\"%s\":%d", sep, $2, $1; sep = "," } END { print "" }')
  by_status="{$by_status}"
  s5xx_out=$(count '$2 >= 500 && $3 == 0')
  s5xx_in=$(count '$2 >= 500 && $3 == 1')
  local s5xx_in_other
  s5xx_in_other=$(count '$2 >= 500 && $3 == 1 && $2 != 502 && $2 != 504')
  unexpected_in=0; unexpected_out=0
  while IFS=$'\t' read -r t _ kind _; do
    [ "$kind" = unexpected ] || continue
    if in_fault_window "$t"; then unexpected_in=$((unexpected_in + 1)); else unexpected_out=$((unexpected_out + 1)); fi
  done <"$work/events.tsv"
  p50=$(replay_percentile 50); p99=$(replay_percentile 99)
  local replay_requests replay_errors
  replay_requests=$(cat "$work"/replay/*.json 2>/dev/null | jq -s 'map(.requests) | add // 0')
  replay_errors=$(cat "$work"/replay/*.json 2>/dev/null | jq -s 'map(.errors) | add // 0')

  echo
  echo "soak: $minutes min, $replicas replicas behind nginx ($nginx_conf), $clients replay clients, tiny images $([ "$tiny" -eq 1 ] && echo on || echo off)"
  echo "faults (kind replica window):"
  awk -F'\t' -v t0="$t0" '{ printf "  %-8s %s  %5d-%d s\n", $1, $2, $3 - t0, $4 - t0 }' "$work/faults.tsv"
  echo "lost edits: $lost (of $(wc -l <"$work/edits.tsv") acknowledged edits and read-backs)"
  echo "store on disk: $(du -sm "$work/store" | cut -f1) MiB (superseded versions stay for the replicas' --gc-grace)"
  echo "crashes: $crashes unasked exits or failed drains, $log_crashes crash lines in the replica logs"
  [ "$crashes" -eq 0 ] || sed 's/^/  /' "$work/crashes.tsv"
  echo "requests through nginx: $requests, by status $by_status"
  echo "5xx outside fault windows: $s5xx_out; inside: $s5xx_in (of which not 502/504: $s5xx_in_other)"
  echo "unexpected answers to the workers: $unexpected_out outside fault windows, $unexpected_in inside"
  awk -F'\t' '$3 == "unexpected" { print $2 ": " $4 }' "$work/events.tsv" | sort | uniq -c | sort -rn | head -n 15 | sed 's/^/  /'
  echo "worker events: $(cut -f2,3 "$work/events.tsv" | tr '\t' ':' | sort | uniq -c | awk '{ printf "%s%s=%d", sep, $2, $1; sep = " " }')"
  echo "slow clients (what each got; N s: when a stalled upload ended):"
  awk -F'\t' '$2 == "slow" { sub(/^[0-9]+ s/, "N s", $4); print $3 ": " $4 }' "$work/events.tsv" | sort | uniq -c | sed 's/^/  /'
  echo "stalled uploads ended after (s): $(awk -F'\t' '$3 == "stalled_upload" { split($4, a, " "); printf "%s%s", sep, a[1]; sep = " " }' "$work/events.tsv")"
  echo "replay: $replay_requests requests in $(find "$work/replay" -name '*.json' | wc -l) runs, $replay_errors failed (non-2xx or no answer, as replay counts them)"
  echo "replayed views answered 200, through nginx: p50 $p50 ms, p99 $p99 ms"
  echo "RSS MiB per replica (median of first / middle / last third; growth last/middle of the process alive at the end):"
  rss_lines=$(rss_plateau)
  while read -r r f mid l ratio; do
    echo "  replica $r: $f / $mid / $l  growth $ratio"
    rss_json+="${rss_json:+,}{\"replica\":$r,\"first_mib\":$f,\"middle_mib\":$mid,\"last_mib\":$l,\"growth\":$([ "$ratio" = n/a ] && echo null || echo "$ratio")}"
    [ "$ratio" = n/a ] || ! awk -v r="$ratio" -v max="$rss_growth" 'BEGIN { exit !(r > max) }' || leak=$((leak + 1))
  done <<<"$rss_lines"

  [ "$lost" -eq 0 ] || failures+=("$lost lost edits")
  [ "$crashes" -eq 0 ] && [ "$log_crashes" -eq 0 ] || failures+=("crashes")
  [ "$s5xx_out" -eq 0 ] && [ "$s5xx_in_other" -eq 0 ] || failures+=("5xx answers")
  [ "$unexpected_out" -eq 0 ] || failures+=("$unexpected_out unexpected answers")
  [ "$leak" -eq 0 ] || failures+=("RSS grew more than ${rss_growth}x")
  [ "$p50" != null ] || failures+=("no replayed view succeeded")

  printf '{"test":"soak","date":"%s","minutes":%d,"replicas":%d,"tiny_images":%s,"faults":%d,"lost_edits":%d,"acknowledged_edits":%d,' \
    "$(date -u +%Y-%m-%dT%H:%M:%SZ)" "$minutes" "$replicas" "$([ "$tiny" -eq 1 ] && echo true || echo false)" \
    "$(wc -l <"$work/faults.tsv")" "$lost" "$(wc -l <"$work/edits.tsv")"
  printf '"crashes":%d,"crash_log_lines":%d,"requests":%d,"by_status":%s,"5xx_outside_faults":%d,"5xx_inside_faults":%d,' \
    "$crashes" "$log_crashes" "$requests" "$by_status" "$s5xx_out" "$s5xx_in"
  printf '"unexpected_outside_faults":%d,"unexpected_inside_faults":%d,"replay_requests":%d,"replay_errors":%d,' \
    "$unexpected_out" "$unexpected_in" "$replay_requests" "$replay_errors"
  printf '"replay_p50_ms":%s,"replay_p99_ms":%s,"rss":[%s],"passed":%s}\n' "$p50" "$p99" "$rss_json" "$([ "${#failures[@]}" -eq 0 ] && echo true || echo false)"
  [ "${#failures[@]}" -eq 0 ] || die "$(IFS=,; echo "${failures[*]}")"
  log "passed"
}

# ---- the run -----------------------------------------------------------------------------------
main() {
  parse_args "$@"
  work=$(mktemp -d "${TMPDIR:-/tmp}/zoomwarp-soak.XXXXXX")
  trap cleanup EXIT INT TERM
  mkdir -p "$work/pids" "$work/replay" "$work/images"
  touch "$work/events.tsv" "$work/edits.tsv" "$work/faults.tsv" "$work/crashes.tsv"

  local name
  for name in "${!replay_images[@]}"; do
    log "ingesting ${replay_images[$name]} for replay into the shared store"
    "$zoomwarp_bin" ingest "$repo_dir/samples/${replay_images[$name]}".* --store "$work/store" \
      --id "${replay_images[$name]}" --quiet >/dev/null
  done
  make_synthetic_images

  start_cluster
  editor_setup

  t0=$(now); deadline=$(( t0 + minutes * 60 ))
  log "load for $minutes min, until $(date -u -d "@$deadline" +%H:%M:%S)"
  local worker i
  for worker in replayer uploader editor deleter slow_clients sampler; do
    "$worker" &
    worker_pid+=($!)
  done
  inject_faults_until_the_end
  log "load over; waiting for the workers to finish their last requests"
  for i in "${!worker_pid[@]}"; do wait "${worker_pid[$i]}" || true; done
  worker_pid=()
  check_replicas
  report_and_check
}

main "$@"
