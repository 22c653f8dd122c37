#!/bin/bash
# watchdog.sh - started first by start.sh, in its process group: waits until the server's owner is
# gone, then runs stop.sh (which spares this process, as it is the one running it). The owner is
# gone when S3_WATCH_FD reads end-of-file (the write end of that pipe is held by the test process
# alone, so the kernel closes it when that process ends, even by SIGKILL), or when the process
# S3_WATCH_PID ends. Exec'd, not a subshell of start.sh, so that its /proc/PID/environ carries
# ZOOMWARP_SWIFT_S3 like every other process stop.sh stops.
set -u
alive() { local s; read -r s 2> /dev/null < "/proc/$1/stat" || return 1; s=${s##*) }; [ "${s%% *}" != Z ]; }
if [ -n "${S3_WATCH_FD:-}" ]; then while read -r -u "$S3_WATCH_FD" _; do :; done; fi
if [ -n "${S3_WATCH_PID:-}" ]; then while alive "$S3_WATCH_PID"; do sleep 0.5; done; fi
exec "$(dirname "$0")/stop.sh"
