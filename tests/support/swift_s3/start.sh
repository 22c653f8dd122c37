#!/bin/bash
# start.sh - a real S3 server on loopback for the tests: a single-node OpenStack Swift 2.30 (Debian's
# python3-swift) with its s3api and tempauth middleware, and a memcached, every socket on 127.0.0.1.
# tests/support/swift_s3.cc runs it (class SwiftS3); README.md says how to run it by hand. Adapted
# from the recipe in /work/shared/s3-swift (issue 29), which the tests must not need at run time.
#
#   S3_DIR=/tmp/s3 S3_PORT=18080 tests/support/swift_s3/start.sh    ...    S3_DIR=/tmp/s3 tests/support/swift_s3/stop.sh
#
# S3: http://127.0.0.1:$S3_PORT, path-style, region us-east-1, access key test:tester, secret testing.
#
# Environment:
#   S3_DIR            all its state (configs, rings, data, logs/, pids): created, must be empty if it
#                     exists; stop.sh removes it
#   S3_PORT           the proxy's (S3) port; the next four: object, container, account, memcached
#   S3_WATCH_FD       an fd open for reading (a pipe whose write end only the owner holds): when it
#                     reads end-of-file, the owner is gone and a watchdog runs stop.sh
#   S3_WATCH_PID      the same for a process id (by hand: S3_WATCH_PID=$$ ties it to your shell)
#   S3_START_TIMEOUT  seconds to wait for the server to answer S3 requests (60)
#   S3_KEEP=1         stop.sh (also on a failed start) leaves S3_DIR and its logs in place
#
# Prints "s3 ready at http://127.0.0.1:PORT after N ms" and exits 0 once a signed S3 request works;
# otherwise prints why with the logs' last lines, stops what it started and exits 1. It never
# installs anything: scripts/setup.sh does.
#
# Every process it starts (the watchdog, memcached, the four Swift servers, and curl and sleep
# while it waits) is in its process group and carries ZOOMWARP_SWIFT_S3=$S3_DIR in its environment
# (/proc/PID/environ: each is exec'd after the export): that is how stop.sh finds them, so none is
# left behind even if this script is killed half-way.
set -euo pipefail

# 0. a process group of our own (the fixture starts us as a group leader already; a shell that
#    runs us without job control does not): setsid from a non-leader keeps the pid, no fork.
pgrp_of() { local s; read -r s < "/proc/$1/stat"; s=${s##*) }; set -- $s; echo "$3"; }
if [ "$(pgrp_of $$)" != $$ ]; then exec setsid "$BASH" "$0" "$@"; fi

here=$(cd "$(dirname "$0")" && pwd)
D=${S3_DIR:?S3_DIR: the folder for the server state}
S3_PORT=${S3_PORT:?S3_PORT: the S3 port; the next four are taken too}
OBJ_PORT=$((S3_PORT+1)) CONT_PORT=$((S3_PORT+2)) ACC_PORT=$((S3_PORT+3)) MC_PORT=$((S3_PORT+4))
PY=/usr/bin/python3   # Debian's: a python3 earlier on PATH (pyenv, venv) may not see python3-swift
t0=$(date +%s%N)

# 1. what it needs, installed by scripts/setup.sh
need() { echo "swift_s3: $1 is missing: run scripts/setup.sh (Debian packages python3-swift memcached curl)" >&2; exit 1; }
[ -f /usr/lib/python3/dist-packages/swift/common/middleware/s3api/s3api.py ] || need "python3-swift (with s3api)"
[ -x /usr/bin/memcached ] || need memcached
command -v curl >/dev/null || need curl
if [ -e "$D" ] && [ -n "$(ls -A "$D")" ]; then echo "swift_s3: $D is not empty (stop.sh it first?)" >&2; exit 1; fi
mkdir -p "$D"
D=$(cd "$D" && pwd -P)
export ZOOMWARP_SWIFT_S3=$D S3_DIR=$D
echo $$ > "$D/pgid"
: > "$D/pids"

# 2. the watchdog (watchdog.sh), first of all: it is in our group and stops it when the owner is gone
alive() { local s; read -r s 2> /dev/null < "/proc/$1/stat" || return 1; s=${s##*) }; [ "${s%% *}" != Z ]; }
if [ -n "${S3_WATCH_FD:-}" ] && [ ! -e "/proc/$$/fd/$S3_WATCH_FD" ]; then
  echo "swift_s3: S3_WATCH_FD=$S3_WATCH_FD is not open" >&2; exit 1
fi
if [ -n "${S3_WATCH_FD:-}${S3_WATCH_PID:-}" ]; then
  # Not our child: a parent that kills its process tree (ctest on a timeout kills the test and its
  # descendants, found by parent pid) must not take the watchdog with it, or nobody removes $D.
  ( "$BASH" "$here/watchdog.sh" < /dev/null > /dev/null 2>&1 & echo "watchdog $!" >> "$D/pids" )
  # no daemon should hold the pipe: only the watchdog reads it
  if [ -n "${S3_WATCH_FD:-}" ]; then eval "exec $S3_WATCH_FD<&-"; fi
fi

fail() {
  echo "swift_s3: $1" >&2
  for f in "$D"/log/*.log; do [ -s "$f" ] && { echo "--- $f (last 15 lines)"; tail -n 15 "$f"; }; done >&2
  S3_STOP_SPARE=$$ "$here/stop.sh"
  exit 1
}

# 3. configs. Swift stores objects' metadata in user xattrs: the data folder must have them.
mkdir -p "$D/etc" "$D/node/d1" "$D/log"
"$PY" -c 'import os, sys; os.setxattr(sys.argv[1], "user.zoomwarp", b"1")' "$D/node/d1" 2> "$D/log/xattr.log" ||
  fail "user xattrs do not work in $D (tmpfs before Linux 6.6?): set TMPDIR to a folder on ext4 or xfs"
cat > "$D/etc/swift.conf" <<EOF
[swift-hash]
swift_hash_path_suffix = s3test
[storage-policy:0]
name = Policy-0
default = yes
EOF
for s in object:$OBJ_PORT container:$CONT_PORT account:$ACC_PORT proxy:$S3_PORT; do
  name=${s%%:*} port=${s##*:}
  cat > "$D/etc/$name-server.conf" <<EOF
[DEFAULT]
bind_ip = 127.0.0.1
bind_port = $port
workers = 0
user = $(id -un)
swift_dir = $D/etc
devices = $D/node
mount_check = false
bind_timeout = 2
EOF
  [ "$name" = proxy ] || printf '[pipeline:main]\npipeline = %s-server\n[app:%s-server]\nuse = egg:swift#%s\n' \
                                "$name" "$name" "$name" >> "$D/etc/$name-server.conf"
done
cat >> "$D/etc/proxy-server.conf" <<EOF
[pipeline:main]
pipeline = catch_errors gatekeeper healthcheck proxy-logging cache listing_formats s3api tempauth copy slo dlo versioned_writes proxy-logging proxy-server
[app:proxy-server]
use = egg:swift#proxy
account_autocreate = true
[filter:s3api]
use = egg:swift#s3api
location = us-east-1
[filter:tempauth]
use = egg:swift#tempauth
user_test_tester = testing .admin
[filter:cache]
use = egg:swift#memcache
memcache_servers = 127.0.0.1:$MC_PORT
EOF
for f in catch_errors gatekeeper healthcheck proxy_logging listing_formats copy slo dlo versioned_writes; do
  printf '[filter:%s]\nuse = egg:swift#%s\n' "${f/_logging/-logging}" "$f" >> "$D/etc/proxy-server.conf"
done

# 4. the servers, in the background (tempauth needs memcached: without it every request logs
#    errors and runs about 3x slower)
/usr/bin/memcached -l 127.0.0.1 -p "$MC_PORT" -U 0 -m 32 -u "$(id -un)" < /dev/null > "$D/log/memcached.log" 2>&1 &
echo "memcached $!" >> "$D/pids"
# swiftd.py imports Swift once, forks the four servers (each logs to log/NAME.log), adds their
# pids to pids and exits
EVENTLET_NO_GREENDNS=yes "$PY" "$here/swiftd.py" "$D/pids" "$D"/etc/{account,container,object,proxy}-server.conf \
  < /dev/null > "$D/log/swiftd.log" 2>&1 || fail "swiftd.py failed"

# 5. ready = every server alive, each backend answers OPTIONS as itself, memcached accepts, and a
#    signed S3 request (ListBuckets) is answered 200. A port taken by someone else ends that
#    server within bind_timeout (2 s): "Could not bind" / "Address already in use" in its log.
ready() {
  for s in object:$OBJ_PORT container:$CONT_PORT account:$ACC_PORT; do
    curl -s -m 1 -X OPTIONS -D - -o /dev/null "http://127.0.0.1:${s#*:}/" | grep -qi "^server: ${s%:*}-server" || return 1
  done
  timeout 1 bash -c "exec 3<>/dev/tcp/127.0.0.1/$MC_PORT" 2>/dev/null || return 1
  [ "$(curl -s -m 2 -o /dev/null -w '%{http_code}' --aws-sigv4 aws:amz:us-east-1:s3 \
         -H 'x-amz-content-sha256: UNSIGNED-PAYLOAD' "http://test%3Atester:testing@127.0.0.1:$S3_PORT/")" = 200 ]
}
timeout_s=${S3_START_TIMEOUT:-60}
deadline=$(( $(date +%s) + timeout_s ))
while [ "$(date +%s)" -lt "$deadline" ]; do
  while read -r name pid; do
    [ "$name" = watchdog ] || alive "$pid" || fail "$name (pid $pid) exited"
  done < "$D/pids"
  if ready; then
    echo "s3 ready at http://127.0.0.1:$S3_PORT after $(( ($(date +%s%N) - t0) / 1000000 )) ms"
    exit 0
  fi
  sleep 0.1
done
fail "S3 not ready after $timeout_s s"
