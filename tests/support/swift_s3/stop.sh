#!/bin/bash
# stop.sh - stops the server start.sh started in $S3_DIR and removes that folder (S3_KEEP=1 keeps it).
#
#   S3_DIR=/tmp/s3 tests/support/swift_s3/stop.sh
#
# It stops every process of start.sh's process group ($S3_DIR/pgid) that carries
# ZOOMWARP_SWIFT_S3=$S3_DIR in its environment, and nothing else: a group id cannot be reused
# while the group has members, and the mark tells ours from a group that took the id later.
# Paused processes (SIGSTOP) are continued first; SIGTERM, then SIGKILL after 3 s. The watchdog of
# start.sh runs this when the test process is gone: it spares itself ($$), and start.sh's failure
# path spares start.sh (S3_STOP_SPARE). Safe to run again.
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

if [ -n "$pg" ]; then
  m=$(members)
  if [ -n "$m" ]; then
    kill -CONT $m 2> /dev/null
    kill -TERM $m 2> /dev/null
    for _ in $(seq 30); do
      m=$(members)
      [ -z "$m" ] && break
      sleep 0.1
    done
    if [ -n "$m" ]; then
      kill -KILL $m 2> /dev/null
      for _ in $(seq 20); do [ -z "$(members)" ] && break; sleep 0.1; done
    fi
  fi
fi
if [ "${S3_KEEP:-0}" = 1 ]; then rm -f "$D/pgid"; else rm -rf "$D"; fi
exit 0
