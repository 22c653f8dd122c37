#!/usr/bin/env bash
# How many replicas compute an image's analysis when its first views reach several at once
# (issue 42): N `zoomwarp serve` on one folder store, an image uploaded without analyses, then one
# first view per replica sent at the same instant (each retried on 503 analysis_pending as its
# Retry-After asks), and a second round after the first is done. Prints, per round, how many
# replicas computed the analysis and how many read it from the store
# (zoomwarp_analyses_total{source=…}), and each round's wall time.
#
#   tests/bench/fleet_first_view.sh [--replicas N] [--image FILE] [--method M] [--zoomwarp BIN]
#
# Needs curl. Replicas listen on 127.0.0.1 only; everything stops at exit.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
replicas=3
image="$repo_dir/samples/boats_lake_sunset.jpg"
method=icaz
zoomwarp_bin="$repo_dir/build/bin/zoomwarp"
while [ $# -gt 0 ]; do
  case "$1" in
    --replicas) replicas="${2:?}"; shift 2 ;;
    --image) image="${2:?}"; shift 2 ;;
    --method) method="${2:?}"; shift 2 ;;
    --zoomwarp) zoomwarp_bin="${2:?}"; shift 2 ;;
    -h|--help) sed -n '2,10p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "fleet_first_view.sh: unknown argument '$1' (--help)" >&2; exit 2 ;;
  esac
done

work=$(mktemp -d)
pids=()
cleanup() { for p in "${pids[@]}"; do kill "$p" 2> /dev/null || true; done; wait 2> /dev/null || true; rm -rf "$work"; }
trap cleanup EXIT
ports=()
start_replica() {  # appends its port to ports
  local i=${#ports[@]} port=""
  "$zoomwarp_bin" serve --store "$work/store" --host 127.0.0.1 --port 0 --open-writes > "$work/r$i.log" 2>&1 &
  pids+=($!)
  for _ in $(seq 200); do
    port=$(grep -o '"port":[0-9]*' "$work/r$i.log" | head -1 | cut -d: -f2 || true)
    [ -n "$port" ] && break
    sleep 0.1
  done
  [ -n "$port" ] || { echo "replica $i did not start: $(cat "$work/r$i.log")" >&2; exit 1; }
  ports+=("$port")
}
for ((k = 0; k < replicas; k++)); do start_replica; done
curl -sf -X POST --data-binary @"$image" "http://127.0.0.1:${ports[0]}/v1/images?id=img" > /dev/null

analyses() {  # "computed read" summed over the replicas
  local c=0 r=0 i
  for i in "${ports[@]}"; do
    c=$((c + $(curl -s "http://127.0.0.1:$i/metrics" | awk '/^zoomwarp_analyses_total\{source="computed"\}/ {print int($2)}')))
    r=$((r + $(curl -s "http://127.0.0.1:$i/metrics" | awk '/^zoomwarp_analyses_total\{source="read"\}/ {print int($2)}')))
  done
  echo "$c $r"
}
first_view() {  # until 200, as a client following Retry-After would
  for _ in $(seq 600); do
    code=$(curl -s -o /dev/null -w '%{http_code}' "http://127.0.0.1:$1/v1/images/img/mesh?w=480&h=360&zoom=0&method=$method")
    [ "$code" = 200 ] && return 0
    sleep 0.5
  done
  return 1
}
round() {  # LABEL PORT...: one first view on each at once
  local label=$1 t0 t1 before after p
  shift
  before=$(analyses)
  t0=$(date +%s.%N)
  local waiting=()
  for p in "$@"; do first_view "$p" & waiting+=($!); done
  for p in "${waiting[@]}"; do wait "$p"; done
  t1=$(date +%s.%N)
  after=$(analyses)
  read -r c0 r0 <<< "$before"
  read -r c1 r1 <<< "$after"
  printf '| %s | %d | %d | %d | %.1f |\n' "$label" "$#" $((c1 - c0)) $((r1 - r0)) "$(echo "$t1 - $t0" | bc -l)"
}
echo "$replicas replicas on one folder store, $(basename "$image"), method $method; $(nproc) cores"
echo
echo "| round | replicas asked | computed the analysis | read it from the store | wall s |"
echo "|---|---:|---:|---:|---:|"
round "first views at once" "${ports[@]}"
start_replica
round "a replica started after" "${ports[-1]}"
