#!/usr/bin/env bash
# Scale-out on loopback: three `zoomwarp serve` replicas sharing one store, nginx in front with
# deploy/nginx.conf (load balancing, a connection per upstream request, retries of failed GETs on
# another replica, a response cache), and `zoomwarp replay` driving tests/load/boats_explore.jsonl
# through nginx with 4 clients while one replica is SIGKILLed and restarted a few seconds later
# and another is SIGTERMed (it drains, as in deploy/compose.yaml) and restarted once it has exited.
#
# Asserts what a viewer would notice: not one failed request (every answer a 2xx, no connection
# error) before, during and after the faults; the replicas come back and take traffic again; a
# second pass over the path is served from nginx's cache. Prints requests, failures and the p99
# per phase (one `zoomwarp replay --json` run per phase: before, during, after the faults), the
# X-Cache-Status counts, and one JSON line at the end. A warm-up first plays the path once straight
# to each replica, filling its response cache (server defaults): 'before' is the steady state.
#
# nginx listens on two ports. The fault phases use the second, where cache lookups are bypassed
# (the one test-only addition to deploy/nginx.conf), so every one of their requests reaches a
# replica however often the path wraps around. Then the path is played twice through the first
# port, the cache as deployed: a first pass that reaches the replicas and fills the cache, and a
# second one whose X-Cache-Status values (from nginx's access log) give the hit ratio.
#
# Every process runs on 127.0.0.1, on ports picked below Linux's ephemeral range (a replica is
# restarted on its port, which no outgoing connection can have taken meanwhile), with everything
# in one temp folder. The EXIT trap stops all of them, also on failure or Ctrl-C.
#
# Run `tests/cluster/cluster_test.sh --help` for the options; CTest runs it as `cluster.scale_out`
# (label cluster).
set -euo pipefail

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"
# shellcheck source=../support/replicas.sh
source "$repo_dir/tests/support/replicas.sh"

# ---- defaults (see usage) -----------------------------------------------------------------------
before=6          # seconds of load before the faults
during=24         # seconds of load around the faults (they take 10-17 s of it)
after=6           # seconds of load after the replicas are back
down=3            # seconds the SIGKILLed replica stays down
clients=4
replicas=3
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
nginx_bin=/usr/sbin/nginx
nginx_conf="$repo_dir/deploy/nginx.conf"
keep=0
view_path="$repo_dir/tests/load/boats_explore.jsonl"
sample="$repo_dir/samples/boats_lake_sunset.jpg"
image_id=boats_lake_sunset

usage() {
  cat <<EOF
usage: tests/cluster/cluster_test.sh [OPTIONS]

Three zoomwarp replicas sharing one store behind nginx with deploy/nginx.conf (retries on another
replica, a connection per upstream request, a response cache); zoomwarp replay drives tests/load/boats_explore.jsonl through nginx
while one replica is SIGKILLed and restarted and another SIGTERMed and restarted. Fails if any
request the clients made failed, if a replica does not come back, or if a second pass over the path
is not served from nginx's cache. Exit codes: 0 passed, 1 failed, 77 skipped (nginx missing).

options:
  --before SEC        load before the faults (default $before)
  --during SEC        load during the faults, at least 14 (default $during)
  --after SEC         load after the replicas are back (default $after)
  --down SEC          how long the SIGKILLed replica stays down (default $down)
  --clients N         replay clients (default $clients)
  --zoomwarp PATH     zoomwarp binary (default build/bin/zoomwarp)
  --nginx PATH        nginx binary (default $nginx_bin)
  --nginx-conf PATH   nginx configuration to template (default deploy/nginx.conf)
  --keep              keep the temp folder (logs, nginx config, replay summaries)
  -h, --help          this text

Needs: nginx (Debian nginx-light), curl, jq; all of them in scripts/setup.sh.
EOF
}

die() { echo "cluster_test: FAILED: $*" >&2; exit 1; }
log() { echo "cluster_test: $*" >&2; }

parse_args() {
  while [ $# -gt 0 ]; do
    case "$1" in
      -h|--help) usage; exit 0 ;;
      --before) before=${2:?--before needs a value}; shift 2 ;;
      --during) during=${2:?--during needs a value}; shift 2 ;;
      --after) after=${2:?--after needs a value}; shift 2 ;;
      --down) down=${2:?--down needs a value}; shift 2 ;;
      --clients) clients=${2:?--clients needs a value}; shift 2 ;;
      --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a value}; shift 2 ;;
      --nginx) nginx_bin=${2:?--nginx needs a value}; shift 2 ;;
      --nginx-conf) nginx_conf=${2:?--nginx-conf needs a value}; shift 2 ;;
      --keep) keep=1; shift ;;
      *) echo "cluster_test: unknown argument $1 (see --help)" >&2; exit 2 ;;
    esac
  done
  local n
  for n in before during after down clients; do
    [[ ${!n} =~ ^[0-9]+$ ]] || { echo "cluster_test: --$n must be a whole number" >&2; exit 2; }
  done
  if [ "$before" -lt 1 ] || [ "$after" -lt 1 ] || [ "$clients" -lt 1 ] || [ "$during" -lt 14 ]; then
    echo "cluster_test: --before, --after and --clients must be at least 1, --during at least 14" >&2; exit 2
  fi
  [ -x "$zoomwarp_bin" ] || die "zoomwarp binary not found at $zoomwarp_bin (build it first)"
  [ -f "$nginx_conf" ] || die "no nginx configuration at $nginx_conf"
  if [ ! -x "$nginx_bin" ]; then
    log "SKIPPED: nginx not found at $nginx_bin (scripts/setup.sh installs nginx-light)"; exit 77
  fi
  local tool
  for tool in curl jq; do command -v "$tool" >/dev/null || die "$tool not found (scripts/setup.sh installs it)"; done
}

# ---- process control ---------------------------------------------------------------------------
# The replicas and nginx's ports are tests/support/replicas.sh's. (A declare without a value
# keeps them, and tells shellcheck, which does not follow `source` without -x, that they exist.)
declare -a replica_pid replica_port replica_log
declare nginx_port nginx_bypass_port
work=""                 # the one temp folder
nginx_pid=""
replay_pid=""

# The replay, then nginx and the replicas (tests/support/replicas.sh); exits.
cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  stop_process "$replay_pid"
  finish_cluster "$rc" "$keep" 20
}

# ---- replicas ----------------------------------------------------------------------------------
# start_replicas and start_replica (tests/support/replicas.sh), no hook and no more flags: the
# server's defaults but for the address, port, store and the drain delay deploy/compose.yaml sets.

# Requests replica I has answered since it was (re)started.
replica_requests() { grep -c '"msg":"request"' "${replica_log[$1]}" 2>/dev/null || true; }
replica_busy() { [ "$(replica_requests "$1")" -ge "$2" ]; }

# ---- nginx -------------------------------------------------------------------------------------
# write_nginx_conf and nginx_answers (tests/support/replicas.sh) template deploy/nginx.conf and
# pick two ports: nginx_port with the deployment's behaviour (cache lookups and fills), and
# nginx_bypass_port for the fault phases, without cache lookups, so that every request reaches a
# replica however often the path wraps around.

# Its access log goes to stdout and its error log to stderr, like the container's.
start_nginx() {
  nginx_start "$nginx_bin" "$work/nginx" write_nginx_conf nginx_answers || die "nginx did not start"
  log "nginx (pid $nginx_pid, $nginx_conf) on 127.0.0.1:$nginx_port, without cache lookups on 127.0.0.1:$nginx_bypass_port"
}

access_lines() { wc -l <"$work/nginx/access.log"; }
access_grew() { [ "$(access_lines)" -ge "$1" ]; }

# "HIT=n MISS=m ..." of the mesh and viewport requests in an excerpt of nginx's access log.
cache_statuses_of() {
  jq -r 'select(.target | test("^/v1/images/[^/]+/(mesh|viewport)\\?")) | if .cache == "" then "-" else .cache end' "$1" |
    sort | uniq -c | awk '{ printf "%s%s=%d", sep, $2, $1; sep = " " } END { print "" }'
}

# ---- replay ------------------------------------------------------------------------------------
# replay PHASE PORT ARGS...: one `zoomwarp replay --json` run against 127.0.0.1:PORT (nginx, or a
# replica for the warm-up), its summary in PHASE.json.
replay() {
  local phase=$1 port=$2; shift 2
  "$zoomwarp_bin" replay "$view_path" --image "$image_id" --url "http://127.0.0.1:$port" \
    --clients "$clients" --json "$@" >"$work/$phase.json" 2>"$work/$phase.err"
}

check_phase() {
  local phase=$1 errors requests
  jq -e . "$work/$phase.json" >/dev/null 2>&1 || { cat "$work/$phase.err" >&2; die "replay ($phase) printed no summary"; }
  requests=$(jq .requests "$work/$phase.json")
  errors=$(jq .errors "$work/$phase.json")
  [ "$requests" -gt 0 ] || die "replay ($phase) made no requests"
  [ "$errors" -eq 0 ] || die "$errors of $requests requests failed in phase '$phase': $(jq -c .errors_by_status "$work/$phase.json") $(jq -r '.first_connection_error // ""' "$work/$phase.json")"
}

# ---- the run -----------------------------------------------------------------------------------
fault_log=()
note() {
  local tenths=$(( ($(date +%s%N) - t0) / 100000000 ))
  fault_log+=("$(printf '%4d.%d s  %s' $((tenths / 10)) $((tenths % 10)) "$*")")
  log "$*"
}

# The faults, while the 'during' replay runs: SIGKILL replica 0 and restart it $down s later, then
# SIGTERM replica 1 and restart it once it has exited. Each step waits for its condition (traffic
# flowing, a replica listening, a replica taking requests again) rather than for a fixed time.
inject_faults() {
  local lines status
  wait_until 10 access_grew $(( $(access_lines) + 100 )) || die "no traffic through nginx"
  note "SIGKILL replica 0 (pid ${replica_pid[0]})"
  kill -KILL "${replica_pid[0]}"
  status=0; { wait "${replica_pid[0]}"; } 2>/dev/null || status=$?   # (no "Killed" line from bash)
  [ "$status" -eq 137 ] || die "replica 0 did not die of SIGKILL (status $status)"
  replica_pid[0]=""
  lines=$(access_lines)
  sleep "$down"   # the outage itself: a replica that is gone for a few seconds
  access_grew $(( lines + 100 )) || die "nginx answered only $(( $(access_lines) - lines )) requests while replica 0 was down"
  note "nginx answered $(( $(access_lines) - lines )) requests while replica 0 was down; restarting it"
  start_replica 0
  wait_until 15 replica_busy 0 20 || die "restarted replica 0 got no traffic"
  note "replica 0 is back and answering ($(replica_requests 0) requests so far)"

  note "SIGTERM replica 1 (pid ${replica_pid[1]})"
  kill -TERM "${replica_pid[1]}"
  status=0; wait "${replica_pid[1]}" || status=$?
  [ "$status" -eq 0 ] || die "replica 1 exited $status after SIGTERM (expected 0)"
  replica_pid[1]=""
  note "replica 1 drained and exited 0; restarting it"
  start_replica 1
  wait_until 15 replica_busy 1 20 || die "restarted replica 1 got no traffic"
  note "replica 1 is back and answering ($(replica_requests 1) requests so far)"
}

p99s() {  # "mesh zoom/pan, viewport zoom/pan" p99 in ms
  jq -r '[.endpoints.mesh.zoom.p99_ms, .endpoints.mesh.pan.p99_ms, .endpoints.viewport.zoom.p99_ms,
          .endpoints.viewport.pan.p99_ms] | map(. // 0 | tostring) | join(" / ")' "$1"
}

main() {
  parse_args "$@"
  work=$(mktemp -d "${TMPDIR:-/tmp}/zoomwarp-cluster.XXXXXX")
  trap cleanup EXIT INT TERM

  log "ingesting $(basename "$sample") into the shared store"
  "$zoomwarp_bin" ingest "$sample" --store "$work/store" --id "$image_id" --quiet >/dev/null

  start_replicas "$replicas" ""
  start_nginx

  # One pass over the path: every client makes ceil(requests / clients) requests from its own
  # starting point (replay plays each action's mesh then its viewport).
  local actions pass_requests per_client i
  actions=$(grep -cvE '^[[:space:]]*(#|$)' "$view_path")
  pass_requests=$(( actions * 2 ))
  per_client=$(( (pass_requests + clients - 1) / clients ))

  # Warm-up, checked but not part of the figures: the path once straight to each replica, so that
  # every replica's response cache holds every view (server defaults) and 'before' is the steady
  # state. (The replicas restarted 'during' start cold again, and 'after' shows them warming.)
  for ((i = 0; i < replicas; i++)); do
    log "warm-up: the path once straight to replica $i"
    replay "warmup$i" "${replica_port[$i]}" --count "$per_client" || die "replay (warm-up $i) could not run: $(cat "$work/warmup$i.err")"
    check_phase "warmup$i"
  done

  t0=$(date +%s%N)
  log "phase 'before': $before s of load through nginx"
  replay before "$nginx_bypass_port" --duration "$before" || die "replay (before) could not run: $(cat "$work/before.err")"
  check_phase before

  log "phase 'during': $during s of load while replicas are killed and restarted"
  local during_start
  during_start=$(date +%s%N)
  replay during "$nginx_bypass_port" --duration "$during" &
  replay_pid=$!
  inject_faults
  local faults_done
  faults_done=$(date +%s%N)
  local replay_status=0
  wait "$replay_pid" || replay_status=$?
  replay_pid=""
  [ "$replay_status" -eq 0 ] || die "replay (during) could not run: $(cat "$work/during.err")"
  # The replay ran for $during s from (just after) during_start: the faults must lie inside it.
  [ $(( faults_done - during_start )) -lt $(( during * 1000000000 )) ] ||
    die "the faults took $(( (faults_done - during_start) / 1000000 )) ms, longer than the 'during' load: give --during more"
  check_phase during

  log "phase 'after': $after s of load with every replica back"
  replay after "$nginx_bypass_port" --duration "$after" || die "replay (after) could not run: $(cat "$work/after.err")"
  check_phase after

  # Through the cache as deployed, the path once to fill it (reaching the replicas), then once more.
  local first_start second_start
  first_start=$(( $(access_lines) + 1 ))
  log "first pass through nginx's cache: the path once ($per_client requests per client)"
  replay first_pass "$nginx_port" --count "$per_client" || die "replay (first pass) could not run"
  check_phase first_pass
  second_start=$(( $(access_lines) + 1 ))
  log "second pass through nginx's cache: the same again"
  replay second_pass "$nginx_port" --count "$per_client" || die "replay (second pass) could not run"
  check_phase second_pass
  local first_statuses second_statuses second_total hits ratio
  head -n $(( second_start - 1 )) "$work/nginx/access.log" | tail -n +"$first_start" >"$work/first_pass.log"
  first_statuses=$(cache_statuses_of "$work/first_pass.log")
  tail -n +"$second_start" "$work/nginx/access.log" >"$work/second_pass.log"
  second_statuses=$(cache_statuses_of "$work/second_pass.log")
  second_total=$(jq -s 'map(select(.target | test("^/v1/images/[^/]+/(mesh|viewport)\\?"))) | length' "$work/second_pass.log")
  hits=$(jq -s 'map(select((.target | test("^/v1/images/[^/]+/(mesh|viewport)\\?")) and .cache == "HIT")) | length' "$work/second_pass.log")
  ratio=$(awk -v h="$hits" -v t="$second_total" 'BEGIN { printf "%.3f", t ? h / t : 0 }')

  # Every answer nginx gave was a 2xx; how many it had to send to a second replica.
  local non2xx retried upstream_errors
  non2xx=$(jq -c 'select(.status < 200 or .status > 299)' "$work/nginx/access.log" | wc -l)
  retried=$(jq -c 'select(.upstream | contains(","))' "$work/nginx/access.log" | wc -l)
  upstream_errors=$(grep -c '\[error\].*upstream' "$work/nginx/error.log" || true)
  if [ "$non2xx" -ne 0 ]; then
    jq -c 'select(.status < 200 or .status > 299)' "$work/nginx/access.log" | head >&2
    die "nginx answered $non2xx requests with a non-2xx status"
  fi

  # ---- report ----
  local phase total_requests=0 total_errors=0
  echo
  echo "three replicas behind nginx ($nginx_conf), $clients replay clients over $(basename "$view_path"):"
  for i in "${fault_log[@]}"; do echo "  $i"; done
  echo
  printf '%-12s %9s %7s %9s   %s\n' phase requests errors "req/s" "p99 ms: mesh zoom / pan, viewport zoom / pan"
  for phase in warmup0 warmup1 warmup2 before during after first_pass second_pass; do
    printf '%-12s %9d %7d %9.1f   %s\n' "$phase" "$(jq .requests "$work/$phase.json")" "$(jq .errors "$work/$phase.json")" \
      "$(jq .requests_per_second "$work/$phase.json")" "$(p99s "$work/$phase.json")"
    total_requests=$(( total_requests + $(jq .requests "$work/$phase.json") ))
    total_errors=$(( total_errors + $(jq .errors "$work/$phase.json") ))
  done
  echo
  echo "nginx: $retried requests retried on another replica ($upstream_errors upstream errors logged), $non2xx non-2xx answers"
  echo "X-Cache-Status, first pass through the cache: $first_statuses"
  echo "X-Cache-Status, second pass: $second_statuses (hit ratio $ratio)"
  jq -cn --argjson requests "$total_requests" --argjson errors "$total_errors" --argjson retried "$retried" \
    --argjson hit_ratio "$ratio" --argjson hits "$hits" --argjson pass "$second_total" \
    --slurpfile before "$work/before.json" --slurpfile during "$work/during.json" --slurpfile after "$work/after.json" \
    --slurpfile second "$work/second_pass.json" \
    '{requests: $requests, errors: $errors, retried_by_nginx: $retried,
      second_pass: {requests: $pass, hits: $hits, hit_ratio: $hit_ratio},
      p99_ms: ({before: $before[0], during: $during[0], after: $after[0], second_pass: $second[0]}
               | map_values(.endpoints | map_values(map_values(.p99_ms))))}'

  [ "$second_total" -ge "$pass_requests" ] || die "the second pass logged $second_total requests, expected at least $pass_requests"
  awk -v r="$ratio" 'BEGIN { exit !(r >= 0.9) }' || die "only $ratio of the second pass came from nginx's cache"
  log "passed"
}

main "$@"
