# shellcheck shell=bash
# A throwaway nginx on loopback for the test and benchmark scripts (tests/cluster/cluster_test.sh,
# tests/soak/soak_test.sh, tests/bench/tiles_vs_nginx.sh). Sourced, not run. Everything nginx
# reads or writes lives in one prefix folder the caller owns (usually inside its temp folder):
#
#   DIR/nginx.conf   the configuration (written by the caller's callback, see nginx_start)
#   DIR/nginx.pid    nginx's pid file
#   DIR/access.log   nginx's stdout: deploy/nginx.conf logs requests to /dev/stdout
#   DIR/error.log    nginx's stderr: errors, also those before the configuration is read
#
# Also the small process helpers nginx_start needs and the callers share: picking a free loopback
# port, waiting for a condition, stopping a process and its children.
#
# Functions print their complaints to stderr and return non-zero; the caller decides to die.

# pick_loopback_port [TAKEN...]: prints a port below Linux's ephemeral range that nothing listens
# on and that is not among TAKEN. Outgoing connections never get one of these as their local
# port, so a replica can be restarted on the port it had.
pick_loopback_port() {
  local port _
  for _ in $(seq 50); do
    port=$(( 20000 + RANDOM % 12000 ))
    if (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; then continue; fi   # taken
    if [[ " $* " == *" $port "* ]]; then continue; fi
    echo "$port"; return 0
  done
  echo "found no free loopback port" >&2
  return 1
}

# wait_until SECONDS COMMAND...: runs COMMAND every 0.05 s until it succeeds; fails after SECONDS.
wait_until() {
  local timeout=$1; shift
  local deadline=$(( $(date +%s%N) + timeout * 1000000000 ))
  until "$@"; do
    [ "$(date +%s%N)" -lt "$deadline" ] || return 1
    sleep 0.05
  done
}

# stop_process PID: SIGTERM, then SIGKILL if the process is still there after 5 s. nginx's workers
# are killed along with their master in that case, because they would outlive a SIGKILLed master.
# Reaps PID when it is a child of this shell.
stop_process() {
  local pid=$1 children=() _
  if [ -z "$pid" ] || ! kill -0 "$pid" 2>/dev/null; then return 0; fi
  mapfile -t children < <(pgrep -P "$pid" 2>/dev/null || true)
  kill -TERM "$pid" 2>/dev/null || true
  for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$pid" 2>/dev/null; then
    echo "pid $pid ignored SIGTERM; killing it" >&2
    kill -KILL "$pid" "${children[@]}" 2>/dev/null || true
  fi
  wait "$pid" 2>/dev/null || true
}

# nginx_globals DIR: the -g directives deploy/nginx.conf leaves to its caller: in the foreground
# (our child, so that traps can stop it), our pid file, and as root workers that run as the
# invoking user (as 'nobody' they could not enter a 0700 temp folder; nginx allows `user` only
# when started as root).
nginx_globals() {
  local globals="daemon off; pid $1/nginx.pid;"
  [ "$(id -u)" -ne 0 ] || globals+=" user $(id -un) $(id -gn);"
  echo "$globals"
}

# nginx_template_deploy_conf SRC DEST VAR PORT BYPASS_PORT ADDRESS...: deploy/nginx.conf (SRC)
# with the three substitutions its header comment names, written to DEST, checked to have happened
# exactly as expected (a changed file fails the caller rather than testing something else):
#   `server zoomwarp:8080 PARAMS;`  -> one such line per ADDRESS (host:port), parameters kept
#   `listen 8080;`                  -> 127.0.0.1:PORT and 127.0.0.1:BYPASS_PORT, the second one
#                                      skipping cache lookups (test only; the cache still fills)
#   /var/cache/nginx                -> the folder VAR
# The bypass port is for load that must reach the replicas however often it repeats a request.
nginx_template_deploy_conf() {
  local src=$1 dest=$2 var=$3 port=$4 bypass=$5; shift 5
  mkdir -p "$var"
  awk -v addresses="$*" -v port="$port" -v bypass="$bypass" -v var="$var" '
    /^[[:space:]]*server[[:space:]]+zoomwarp:8080([[:space:]][^;]*)?;/ {
      n = split(addresses, a, " ")
      for (i = 1; i <= n; i++) { line = $0; sub(/zoomwarp:8080/, a[i], line); print line }
      servers++; next
    }
    /^[[:space:]]*listen[[:space:]]+8080;/ {
      indent = $0; sub(/[^[:space:]].*/, "", indent)
      print indent "listen 127.0.0.1:" port ";"
      print indent "# tests only: the second port skips cache lookups (the cache still fills)."
      print indent "listen 127.0.0.1:" bypass ";"
      print indent "set $test_cache_bypass 0;"
      print indent "if ($server_port = " bypass ") { set $test_cache_bypass 1; }"
      print indent "proxy_cache_bypass $test_cache_bypass;"
      listens++; next
    }
    /\/var\/cache\/nginx/ { paths += gsub(/\/var\/cache\/nginx/, var) }
    { print }
    END {
      if (servers != 1 || listens != 1 || paths < 1) {
        printf "%s no longer has the lines the tests substitute (see its header comment): found %d upstream server lines (zoomwarp:8080), %d `listen 8080;` lines, %d /var/cache/nginx paths\n", \
          FILENAME, servers, listens, paths > "/dev/stderr"
        exit 1
      }
    }' "$src" >"$dest"
}

# nginx_start BIN DIR WRITE_CONF READY: starts nginx BIN in the background with prefix DIR and
# DIR/nginx.conf, and sets nginx_pid. WRITE_CONF is a command that picks the ports and writes
# DIR/nginx.conf (nginx cannot pick a port itself); READY a command that succeeds once nginx
# answers on them. Both are run again, up to 5 times, when another process won the race for a
# port ("Address already in use"). Fails, with nginx stopped and its errors on stderr, otherwise.
nginx_start() {
  local bin=$1 dir=$2 write_conf=$3 ready=$4 _
  nginx_pid=""
  mkdir -p "$dir"
  for _ in 1 2 3 4 5; do
    "$write_conf" || return 1
    "$bin" -p "$dir" -e stderr -g "$(nginx_globals "$dir")" -c "$dir/nginx.conf" \
      >"$dir/access.log" 2>"$dir/error.log" &
    nginx_pid=$!
    if wait_until 10 "$ready" && kill -0 "$nginx_pid" 2>/dev/null; then return 0; fi
    stop_process "$nginx_pid"; nginx_pid=""
    grep -qs "Address already in use" "$dir/error.log" || { cat "$dir/error.log" >&2; echo "nginx did not start" >&2; return 1; }
  done
  echo "found no free ports for nginx" >&2
  return 1
}
