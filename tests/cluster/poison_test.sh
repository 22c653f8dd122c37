#!/usr/bin/env bash
# One bad request costs at most two replicas, never the fleet (issue 17): three replicas of
# zoomwarp_poisonable (the test-only build of the server, tests/support/compute_hook_poison.cc)
# sharing one store behind nginx with deploy/nginx.conf.
#
# Poison: every replica aborts on one request (ZOOMWARP_TEST_POISON). Sent once through nginx,
# it must be tried on at most 2 replicas (nginx's access log lists the upstreams it tried), kill
# at most 2 of them (counted: processes gone), and the client must get an error, not a hang; the
# replica left keeps answering views through nginx.
#
# Slow request: one request holds its worker until the server's deadline (ZOOMWARP_TEST_SLOW).
# `zoomwarp replay` measures other clients' p99 through nginx without, then with, a client
# retrying that request in a loop as fast as its answers come; the p99 with the loop must stay
# within 2× the p99 without it (each endpoint and action of replay's summary; both runs on the
# same replicas, one after the other). The failure cache answers the retries from memory once a
# replica has seen the request run out of time, so the loop cannot pin the workers.
#
# Every process runs on 127.0.0.1 in one temp folder; the EXIT trap stops all of them. CTest runs
# it as `cluster.poison` (label cluster).
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../support/replicas.sh
source "$repo_dir/tests/support/replicas.sh"

# ---- defaults (see usage) -----------------------------------------------------------------------
replicas=3
clients=4
duration=8          # seconds of each replay run (without and with the retry loop)
request_timeout=2   # the replicas' --request-timeout: how long the slow request holds a worker
zoomwarp_bin="$repo_dir/build/bin/zoomwarp_poisonable"
nginx_bin=/usr/sbin/nginx
nginx_conf="$repo_dir/deploy/nginx.conf"
keep=0
view_path="$repo_dir/tests/load/boats_explore.jsonl"
sample="$repo_dir/samples/boats_lake_sunset.jpg"
image_id=boats_lake_sunset
poison_target="/v1/images/$image_id/viewport?w=480&h=360&zoom=0.37&cx=800&cy=500"
slow_target="/v1/images/$image_id/mesh?w=480&h=360&zoom=0.41&cx=700&cy=450"

usage() {
  cat <<EOF
usage: tests/cluster/poison_test.sh [OPTIONS]

Three replicas of zoomwarp_poisonable behind nginx (deploy/nginx.conf). A request that aborts
every replica it reaches must cost at most 2 of them and answer the client with an error; a
client retrying a request that runs out of time must not raise other clients' p99 above 2× its
value without that client. Exit codes: 0 passed, 1 failed, 77 skipped (nginx missing).

options:
  --duration SEC      each replay run, without and with the retry loop (default $duration)
  --clients N         replay clients (default $clients)
  --zoomwarp PATH     the zoomwarp_poisonable binary (default build/bin/zoomwarp_poisonable)
  --nginx PATH        nginx binary (default $nginx_bin)
  --nginx-conf PATH   nginx configuration to template (default deploy/nginx.conf)
  --keep              keep the temp folder (logs, nginx config, replay summaries)
  -h, --help          this text

Needs: nginx (Debian nginx-light), curl, jq; all of them in scripts/setup.sh.
EOF
}

die() { echo "poison_test: FAILED: $*" >&2; exit 1; }
log() { echo "poison_test: $*" >&2; }

parse_args() {
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --duration) duration=${2:?--duration needs a value}; shift 2 ;;
      --clients) clients=${2:?--clients needs a value}; shift 2 ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --nginx) nginx_bin=${2:?--nginx needs a value}; shift 2 ;;
      --nginx-conf) nginx_conf=${2:?--nginx-conf needs a value}; shift 2 ;;
      --keep) keep=1; shift ;;
      *) echo "poison_test: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
  done
  [[ $duration =~ ^[0-9]+$ && $duration -ge 2 ]] || { echo "poison_test: --duration must be a whole number >= 2" >&2; exit 2; }
  [[ $clients =~ ^[0-9]+$ && $clients -ge 1 ]] || { echo "poison_test: --clients must be a whole number >= 1" >&2; exit 2; }
  [ -x "$zoomwarp_bin" ] || die "zoomwarp_poisonable not found at $zoomwarp_bin (scripts/build.sh zoomwarp_poisonable)"
  [ -f "$nginx_conf" ] || die "no nginx configuration at $nginx_conf"
  if [ ! -x "$nginx_bin" ]; then
    log "SKIPPED: nginx not found at $nginx_bin (scripts/setup.sh installs nginx-light)"; exit 77
  fi
  local tool
  for tool in curl jq; do command -v "$tool" >/dev/null || die "$tool not found (scripts/setup.sh installs it)"; done
}

declare -a replica_pid replica_port replica_log
declare nginx_port nginx_bypass_port
work=""
nginx_pid=""
loop_pid=""

cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  stop_process "$loop_pid"
  finish_cluster "$rc" "$keep" 20
}

alive() { kill -0 "$1" 2>/dev/null; }

# ---- poison -------------------------------------------------------------------------------------
# The poison request once through nginx: its status (000: no answer within the limit), the
# upstreams nginx's access log says it tried, the replicas left alive.
poison_case() {
  local status rc=0 tried dead=0 i survivor=""
  status=$(curl -s -o "$work/poison.body" -w '%{http_code}' --max-time 30 "http://127.0.0.1:$nginx_bypass_port$poison_target") || rc=$?
  [ "$rc" -ne 28 ] || die "the poison request hung (no answer in 30 s)"
  # The line is written when the request ends; a replica's death is seen by then.
  wait_until 5 grep -qF "\"target\":\"$poison_target\"" "$work/nginx/access.log" || die "nginx logged no line for the poison request"
  tried=$(grep -F "\"target\":\"$poison_target\"" "$work/nginx/access.log" | tail -n 1 | jq -r '.upstream' | tr ',' '\n' | grep -c .)
  for i in "${!replica_pid[@]}"; do
    if alive "${replica_pid[$i]}"; then survivor=$i; else dead=$((dead + 1)); fi
  done
  log "poison: client got $status; nginx tried $tried upstream(s); $dead of $replicas replicas killed"
  [[ $status =~ ^5[0-9][0-9]$ ]] || die "the poison request was answered $status, not a 5xx error"
  [ "$tried" -le 2 ] || die "the poison request was tried on $tried upstreams (at most 2)"
  [ "$dead" -ge 1 ] || die "no replica died: the poison hook did not fire"
  [ "$dead" -le 2 ] || die "$dead replicas died of one request (at most 2)"
  [ "$dead" -eq "$tried" ] || die "$dead replicas died but nginx tried $tried"
  [ -n "$survivor" ] || die "no replica left"
  # Views nobody asked for yet (new centres), so that the replica left computes them: straight to
  # it, then through nginx until nginx has marked the dead ones down (max_fails): a request may
  # meet both dead replicas first and get 502 (its 2 tries spent on refused connections).
  local view="/v1/images/$image_id/viewport?w=480&h=360&zoom=0.2&cy=600&cx"
  status=$(curl -s -o /dev/null -w '%{http_code}' --max-time 30 "http://127.0.0.1:${replica_port[$survivor]}$view=900") || true
  [ "$status" = 200 ] || die "after the poison, the replica left answered a view $status"
  local cx refused=0
  for cx in 910 920 930 940 950 960 970 980; do
    status=$(curl -s -o /dev/null -w '%{http_code}' --max-time 30 "http://127.0.0.1:$nginx_bypass_port$view=$cx") || true
    [ "$status" = 200 ] && break
    [ "$status" = 502 ] || die "after the poison, a view through nginx was answered $status"
    refused=$((refused + 1))
  done
  [ "$status" = 200 ] || die "after the poison, nginx answered no view within 8 requests"
  log "after the poison: the replica left answers; nginx answered $refused view(s) 502 before marking the dead replicas down"
  poison_summary="{\"tried\":$tried,\"killed\":$dead,\"502s_after\":$refused}"
}

# ---- slow request -------------------------------------------------------------------------------
# replay NAME: other clients' views through nginx for $duration s; their p99s, one per endpoint and
# action (mesh zoom, mesh pan, viewport zoom, viewport pan), space-separated.
replay() {
  local name=$1
  "$zoomwarp_bin" replay "$view_path" --image "$image_id" --url "http://127.0.0.1:$nginx_bypass_port" \
    --clients "$clients" --duration "$duration" --json >"$work/$name.json" 2>"$work/$name.err" ||
    { cat "$work/$name.err" >&2; die "replay ($name) could not run"; }
  local errors
  errors=$(jq '[.endpoints[][] | .errors] | add' "$work/$name.json")
  [ "$errors" -eq 0 ] || die "replay ($name): $errors failed requests"
  jq -r '[.endpoints.mesh.zoom.p99_ms, .endpoints.mesh.pan.p99_ms, .endpoints.viewport.zoom.p99_ms,
          .endpoints.viewport.pan.p99_ms] | map(. // 0 | tostring) | join(" ")' "$work/$name.json"
}

# The client that retries the slow request as fast as its answers come, counting its answers.
retry_loop() {
  while :; do
    curl -s -o /dev/null -w '%{http_code}\n' --max-time 30 "http://127.0.0.1:$nginx_bypass_port$slow_target" || echo 000
  done >"$work/retries.txt"
}

slow_case() {
  local without with
  # A warm-up run first: both measured runs then find the same views in the replicas' response
  # caches (steady state), and differ only by the retry loop.
  replay warmup >/dev/null
  without=$(replay without)
  retry_loop &
  loop_pid=$!
  with=$(replay with)
  stop_process "$loop_pid"; loop_pid=""
  local answers fast
  answers=$(grep -c . "$work/retries.txt" || true)
  fast=$(grep -c '^503$' "$work/retries.txt" || true)
  log "slow request: other clients' p99 (ms; mesh zoom, mesh pan, viewport zoom, viewport pan) without the retry loop: $without; with it: $with; the loop got $answers answers, $fast of them 503"
  [ "$fast" -ge 1 ] || die "the retried request was never answered 503"
  local a b ratio worst=0 i
  read -r -a a <<<"$without"
  read -r -a b <<<"$with"
  for i in 0 1 2 3; do
    ratio=$(awk -v x="${b[$i]}" -v y="${a[$i]}" 'BEGIN { printf "%.2f", (y > 0 ? x / y : 0) }')
    awk -v r="$ratio" -v w="$worst" 'BEGIN { exit !(r > w) }' && worst=$ratio
  done
  slow_summary="{\"p99_without_ms\":\"$without\",\"p99_with_ms\":\"$with\",\"worst_ratio\":$worst,\"retries\":$answers}"
  awk -v w="$worst" 'BEGIN { exit !(w <= 2) }' || die "a client retrying a request that runs out of time raised other clients' p99 $worst× (at most 2×)"
}

main() {
  parse_args "$@"
  work=$(mktemp -d "${TMPDIR:-/tmp}/zoomwarp-poison.XXXXXX")
  trap cleanup EXIT INT TERM
  log "ingesting $(basename "$sample") into the shared store"
  "$zoomwarp_bin" ingest "$sample" --store "$work/store" --id "$image_id" --quiet >/dev/null
  export ZOOMWARP_TEST_POISON=$poison_target ZOOMWARP_TEST_SLOW=$slow_target
  start_replicas "$replicas" "" --request-timeout "$request_timeout"
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_answers || die "nginx did not start"

  # The slow case first, with all replicas up; then the poison, which leaves one.
  local poison_summary slow_summary
  slow_case
  poison_case
  echo "{\"poison\":$poison_summary,\"slow\":$slow_summary}"
}

main "$@"
