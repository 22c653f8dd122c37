#!/bin/bash
# stop.sh - stops the server start.sh started in $S3_DIR and removes that folder (S3_KEEP=1 keeps it).
#
#   S3_DIR=/tmp/s3 tests/support/swift_s3/stop.sh
#
# It stops every process of start.sh's process group ($S3_DIR/pgid) that carries
# ZOOMWARP_SWIFT_S3=$S3_DIR in its environment, and nothing else: a group id cannot be reused
# while the group has members, and the mark tells ours from a group that took the id later.
# They are SIGKILLed, paused (SIGSTOP) ones too. The watchdog of start.sh runs this when the test
# process is gone: it spares itself ($$) and the processes in S3_STOP_SPARE (the watchdog running
# it, or start.sh on its failure path). Safe to run again.
set -u
D=${S3_DIR:?S3_DIR: the folder start.sh was given}
[ -d "$D" ] || exit 0
D=$(cd "$D" && pwd -P)
pg=
[ -r "$D/pgid" ] && read -r pg < "$D/pgid"

members() {  # live processes of the group with our mark, but this script and its own children
  local f s pid state ppid pgrp
  for f in /proc/[0-9]*/stat; do
    read -r s 2> /dev/null < "$f" || continue
    pid=${f#/proc/} pid=${pid%/stat}
    s=${s##*) }
    read -r state ppid pgrp _ <<< "$s"
    [ "$pgrp" = "$pg" ] && [ "$state" != Z ] || continue
    case " $$ $BASHPID ${S3_STOP_SPARE:-} " in *" $pid "*) continue ;; esac
    [ "$ppid" = $$ ] || [ "$ppid" = "$BASHPID" ] && continue
    grep -qzxF "ZOOMWARP_SWIFT_S3=$D" "/proc/$pid/environ" 2> /dev/null && echo "$pid"
  done
}

# SIGKILL: the store is thrown away, and a server still importing Swift may not act on SIGTERM
# for seconds. Again until none is left, should one have forked (swiftd.py forking the servers).
if [ -n "$pg" ]; then
  for _ in $(seq 50); do
    m=$(members)
    [ -z "$m" ] && break
    echo "$(date -u +%T.%3N) SIGKILL" $m
    kill -KILL $m 2> /dev/null
    sleep 0.05
  done
fi
if [ "${S3_KEEP:-0}" = 1 ]; then
  rm -f "$D/pgid"
else
  # again should a process that was still exiting have left a file behind the first pass
  for _ in 1 2 3 4 5; do rm -rf "$D" && break; sleep 0.2; done
  [ -e "$D" ] && { echo "$D: not removed; what is left:"; ls -laR "$D" | head -40; }
fi
exit 0
