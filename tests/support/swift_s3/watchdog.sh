#!/bin/bash
# watchdog.sh - started first by start.sh, in its process group: waits until the server's owner is
# gone, then runs stop.sh. The owner is gone when S3_WATCH_FD reads end-of-file (the write end of
# that pipe is held by the test process alone, so the kernel closes it when that process ends, even
# by SIGKILL), or when the process S3_WATCH_PID ends; with both set, whichever comes first (a child
# that kept the pipe's write end by mistake then cannot keep the server alive). Run by start.sh with
# ZOOMWARP_SWIFT_S3 in its environment, so that stop.sh would find it like every other process:
# stop.sh spares it (S3_STOP_SPARE). What stop.sh prints goes to $S3_DIR.watchdog.log, next to
# the folder, which is removed with the folder: a log left there says why the folder was not.
set -u
# A signal to the group is not the owner going: the kernel sends SIGHUP (then SIGCONT) to every
# process of a group that becomes orphaned while one of them is stopped (pause() stops the proxy),
# and Swift's run_wsgi (with workers) SIGTERMs its group when it stops. Ignored here, and so in stop.sh.
# Both killed the watchdog and stop.sh half-way before, leaving the folder (the test
# SwiftS3Fixture.ItsWatchdogOutlivesAHangupOfItsGroup).
trap '' HUP TERM
alive() { local s; read -r s 2> /dev/null < "/proc/$1/stat" || return 1; s=${s##*) }; [ "${s%% *}" != Z ]; }
owner_alive() { [ -z "${S3_WATCH_PID:-}" ] || alive "$S3_WATCH_PID"; }
now() { date -u +%FT%T.%3NZ; }
since=$(now)
why="process ${S3_WATCH_PID:-} ended"
if [ -n "${S3_WATCH_FD:-}" ]; then
  while owner_alive; do
    read -r -t 1 -u "$S3_WATCH_FD" _
    rc=$?
    # 1: end of file; > 128: timed out, look again
    [ $rc -eq 0 ] || [ $rc -gt 128 ] || { why="the pipe closed (read: $rc)"; break; }
  done
elif [ -n "${S3_WATCH_PID:-}" ]; then
  while owner_alive; do sleep 0.5; done
fi
log="$S3_DIR.watchdog.log"
echo "$(now) owner gone ($why; watching since $since), stopping $S3_DIR" >> "$log"
S3_STOP_SPARE="$$ ${S3_STOP_SPARE:-}" "$(dirname "$0")/stop.sh" >> "$log" 2>&1
if [ -e "$S3_DIR" ]; then echo "$(now) $S3_DIR is still there" >> "$log"; else rm -f "$log"; fi
