# shellcheck shell=bash
# Replicas of `zoomwarp serve` sharing one store on loopback (a folder, or a bucket and then no
# folder at all), with nginx (deploy/nginx.conf) in front: the cluster that
# tests/cluster/cluster_test.sh, tests/cluster/s3_cluster_test.sh and tests/soak/soak_test.sh each
# set up.
# Sourced, not run, after tests/support/nginx.sh (whose port picking, waiting, process stopping
# and nginx_start it uses).
#
# A file of its own rather than part of nginx.sh: nginx.sh is the throwaway nginx alone, also
# sourced by tests/bench/tiles_vs_nginx.sh, which runs no replicas; and it keeps no state and
# leaves dying to its caller. These helpers own the cluster's state (the arrays and ports below,
# which the caller reads: a replica's pid to kill it, its port to reach it directly, its log) and
# die on failure with the caller's die and log, as a test cannot go on without its replicas.
#
# The caller provides the functions die MESSAGE (exits) and log MESSAGE, and the variables
#   work                       the temp folder: the store is work/store, replica logs
#                              work/replicaI.N.log, nginx's prefix folder work/nginx
#   zoomwarp_bin, nginx_conf   the zoomwarp binary; deploy/nginx.conf (or a stand-in)
# and, for replicas that share a bucket and no folder (tests/cluster/s3_cluster_test.sh), may set
#   replica_store              every replica's --store instead of work/store (s3://BUCKET/PREFIX,
#                              with the AWS_* variables in the environment)
#   replica_cache_root         each replica's own --store-cache is replica_cache_root/replicaI,
#                              kept across its restarts and shared with no other replica
# then calls start_replicas, start_replica I to restart a replica, nginx_start with
# write_nginx_conf and nginx_answers, and finish_cluster in its EXIT trap. What differs between
# callers (more `serve` flags, a hook that publishes each replica's pid, how much of nginx's error
# log to show) and the caller's options (--keep) go to these functions as arguments.

declare -a replica_pid replica_port replica_log  # per replica: current pid, port, log file
declare -a replica_serve_flags   # start_replicas' SERVE_FLAGs
replica_started_hook=""  # start_replicas' HOOK
replica_store=""         # the caller's: --store of every replica ("" for work/store)
replica_cache_root=""    # the caller's: each replica's --store-cache is in it ("" for none)
replica_starts=0         # numbers each replica log file
starting_cluster=0       # 1 while start_replicas runs: a replica may then move to another port
drain_delay=2            # ZOOMWARP_DRAIN_DELAY in deploy/compose.yaml
nginx_port=""            # the deployment's behaviour: cache lookups and fills
nginx_bypass_port=""     # no cache lookups, so every request reaches a replica

# A free loopback port that none of our processes has (tests/support/nginx.sh).
pick_port() {
  pick_loopback_port "${replica_port[@]:-}" "$nginx_port" "$nginx_bypass_port" || die "found no free port"
}

listening() { grep -q '"msg":"listening"' "$1" 2>/dev/null; }

# start_replica I: starts replica I on its port (picking one the first time) with the server's
# defaults but for the address, port, store (and its cache folder, see replica_cache_root), the
# drain delay deploy/compose.yaml sets and the SERVE_FLAGs given to start_replicas; waits for its
# 'listening' line, then runs HOOK I.
# shellcheck disable=SC2154  # work and zoomwarp_bin are the caller's
start_replica() {
  local i=$1 _ store_flags=(--store "${replica_store:-$work/store}")
  if [ -n "$replica_cache_root" ]; then
    mkdir -p "$replica_cache_root/replica$i"
    store_flags+=(--store-cache "$replica_cache_root/replica$i")
  fi
  for _ in 1 2 3 4 5; do
    [ -n "${replica_port[$i]:-}" ] || replica_port[$i]=$(pick_port) || exit 1
    replica_starts=$((replica_starts + 1))
    replica_log[$i]="$work/replica$i.$replica_starts.log"
    "$zoomwarp_bin" serve --host 127.0.0.1 --port "${replica_port[$i]}" "${store_flags[@]}" \
      --drain-delay "$drain_delay" "${replica_serve_flags[@]}" 2>"${replica_log[$i]}" >/dev/null &
    replica_pid[$i]=$!
    if wait_until 20 listening "${replica_log[$i]}"; then
      [ -z "$replica_started_hook" ] || "$replica_started_hook" "$i"
      log "replica $i (pid ${replica_pid[$i]}) listening on 127.0.0.1:${replica_port[$i]}"
      return 0
    fi
    stop_process "${replica_pid[$i]}"; replica_pid[$i]=""
    # Lost a race for a newly picked port: pick another. A restart keeps its port (nginx knows it).
    if grep -q "cannot listen" "${replica_log[$i]}" && [ "$starting_cluster" -eq 1 ]; then
      replica_port[$i]=""; continue
    fi
    cat "${replica_log[$i]}" >&2
    die "replica $i did not start on port ${replica_port[$i]}"
  done
  die "replica $i found no free port"
}

# start_replicas N HOOK [SERVE_FLAG...]: starts replicas 0 to N-1, each on a port of its own.
# HOOK ("" for none) is a command that start_replica runs with I once replica I listens (before
# it logs that), e.g. to publish its pid and port; the SERVE_FLAGs are added to the `zoomwarp
# serve` command line of every start and restart.
start_replicas() {
  local n=$1 i
  replica_started_hook=$2
  replica_serve_flags=("${@:3}")
  starting_cluster=1
  for ((i = 0; i < n; i++)); do start_replica "$i"; done
  starting_cluster=0
}

# nginx_start's two callbacks (tests/support/nginx.sh). write_nginx_conf: deploy/nginx.conf
# templated, the replicas as upstream servers, two new ports, the cache in our temp folder. The
# bypass (test only) skips cache lookups on the second port: load that wraps around its path many
# times would reach the replicas only on its first pass through the cache.
# shellcheck disable=SC2154  # work and nginx_conf are the caller's
write_nginx_conf() {
  local addresses=() i
  nginx_port=$(pick_port) || exit 1
  nginx_bypass_port=$(pick_port) || exit 1
  for i in "${!replica_port[@]}"; do addresses+=("127.0.0.1:${replica_port[$i]}"); done
  nginx_template_deploy_conf "$nginx_conf" "$work/nginx/nginx.conf" "$work/nginx/var" \
    "$nginx_port" "$nginx_bypass_port" "${addresses[@]}"
}

nginx_answers() {
  curl -s -o /dev/null "http://127.0.0.1:$nginx_port/healthz" && curl -s -o /dev/null "http://127.0.0.1:$nginx_bypass_port/healthz"
}

# finish_cluster RC KEEP LINES: the end of the caller's EXIT trap, once its own processes are
# stopped: stops nginx (nginx_start's nginx_pid) and the replicas; if RC is a failure (not 0, not
# 77 for skipped) shows the last LINES lines of nginx's error.log and each replica's last warnings
# and errors; keeps the temp folder if KEEP is 1, else removes it; exits RC.
# shellcheck disable=SC2154  # work is the caller's, nginx_pid nginx.sh's
finish_cluster() {
  local rc=$1 keep=$2 lines=$3 i
  stop_process "$nginx_pid"
  for i in "${!replica_pid[@]}"; do stop_process "${replica_pid[$i]}"; done
  if [ -n "$work" ] && [ -d "$work" ]; then
    if [ "$rc" -ne 0 ] && [ "$rc" -ne 77 ]; then
      [ -s "$work/nginx/error.log" ] && { log "nginx error.log (last lines):"; tail -n "$lines" "$work/nginx/error.log" >&2; }
      for i in "${!replica_log[@]}"; do
        log "replica $i log (last warnings and errors):"
        grep -v '"level":"info"' "${replica_log[$i]}" 2>/dev/null | tail -n 10 >&2 || true
      done
    fi
    if [ "$keep" -eq 1 ]; then log "kept $work"; else rm -rf "$work"; fi
  fi
  exit "$rc"
}
