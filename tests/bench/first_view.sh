#!/usr/bin/env bash
# The first view of each method with each saliency kind against later views (issue 28): the
# server computes an image's analysis for a method on the first view that needs it, so the first
# view pays for it and the later ones should not.
#
# For a ~1 MP and a ~16 MP photograph (crops of corpus photographs, JPEG Q85) uploaded to a fresh
# `zoomwarp serve` (127.0.0.1, a free port, a temp store, --open-writes), for every method of
# `GET /v1/methods` and every saliency kind (traditional: none), in that order: the time of the
# first `GET …/viewport?zoom=0&w=360&h=640` — a 503 with Retry-After (analysis_pending: the view
# ran out of --request-timeout waiting for the analysis) is retried after Retry-After, and the time
# is until the 200 — then the median of three later views (zoom 0.3, 0.6, 0.9). Twice: idle, and
# loaded by two busy-looping processes; each time on a fresh server and store.
#
# Everything lives in one temp folder; the EXIT trap stops the server and the busy loops and
# removes it. Run `tests/bench/first_view.sh --help` for the options.
set -euo pipefail
export LC_ALL=C

script_dir=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
repo_dir=$(cd "$script_dir/../.." && pwd)
# shellcheck source=../support/nginx.sh
source "$repo_dir/tests/support/nginx.sh"      # stop_process
# shellcheck source=../support/wrk_bench.sh
source "$repo_dir/tests/support/wrk_bench.sh"  # zoomwarp_serve

zoomwarp_bin="$repo_dir/build-release/bin/zoomwarp"
corpus="$repo_dir/../shared/corpus"
small_photo=lake_hill_reflection.jpg
large_photo=nuthatch_tree_trunk.jpg
modes="idle,loaded"
images="1mp,16mp"
method_filter=""
request_timeout=30
max_retries=10
fresh_upload=0
out_file=""
screen_w=360
screen_h=640
later_zooms=(0.3 0.6 0.9)
busy_count=2

usage() {
  cat <<EOF
usage: tests/bench/first_view.sh [OPTIONS]

Uploads a ~1 MP and a ~16 MP photograph to a fresh zoomwarp server and times, for every method of
GET /v1/methods with every saliency kind (traditional: none), in that order, the first
${screen_w}x$screen_h /viewport at zoom 0 (until its 200: a 503 is retried after its Retry-After, up to
--max-retries times) and the median of three later views (zoom ${later_zooms[*]}). Idle, then loaded by
$busy_count busy-looping processes, each on a fresh server and store. Prints a Markdown table.
Needs curl, jq and vips (libvips-tools).

Images (JPEG Q85, metadata stripped, centre crops):
  1mp   1224x816 of the corpus's $small_photo (--small-photo)
  16mp  4896x3264 (16.0 MP) of the corpus's $large_photo (--large-photo; 6028x3391)

options:
  --zoomwarp PATH       zoomwarp binary (default build-release/bin/zoomwarp)
  --corpus DIR          the corpus (default ../shared/corpus from the repository)
  --small-photo NAME    corpus file the 1 MP crop is made of (default $small_photo)
  --large-photo NAME    corpus file the 16 MP crop is made of (default $large_photo)
  --images LIST         1mp, 16mp, comma-separated (default $images)
  --modes LIST          idle, loaded, comma-separated, run in that order (default $modes)
  --methods LIST        only these methods, comma-separated (default: every one the server lists)
  --fresh-upload        upload the image anew for every method and saliency (its own id), so each
                        first view starts from the pyramid alone; default: one upload per image, so
                        an analysis two methods share (saliency maps, detected lines; traditional
                        is ICAZ's default engine) is paid by the first of them in the list
  --request-timeout S   the server's --request-timeout (default $request_timeout)
  --max-retries N       retries of a 503 per view before it is reported as it is (default $max_retries)
  --out FILE            also write the Markdown to FILE
  -h, --help            this text

Other \`zoomwarp serve\` options can be set through their environment variables, e.g.
ZOOMWARP_ANALYSIS_THREADS=2 tests/bench/first_view.sh.
EOF
}

die() { echo "first_view: error: $*" >&2; exit 1; }
log() { echo "[$(date +%T)] $*" >&2; }

while (($#)); do
  case "$1" in
    --zoomwarp) zoomwarp_bin=${2:?--zoomwarp needs a path}; shift 2 ;;
    --corpus) corpus=${2:?--corpus needs a folder}; shift 2 ;;
    --small-photo) small_photo=${2:?--small-photo needs a file name}; shift 2 ;;
    --large-photo) large_photo=${2:?--large-photo needs a file name}; shift 2 ;;
    --images) images=${2:?--images needs a list}; shift 2 ;;
    --modes) modes=${2:?--modes needs a list}; shift 2 ;;
    --methods) method_filter=${2:?--methods needs a list}; shift 2 ;;
    --fresh-upload) fresh_upload=1; shift ;;
    --request-timeout) request_timeout=${2:?--request-timeout needs seconds}; shift 2 ;;
    --max-retries) max_retries=${2:?--max-retries needs a count}; shift 2 ;;
    --out) out_file=${2:?--out needs a file}; shift 2 ;;
    -h | --help) usage; exit 0 ;;
    *) echo "unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ $request_timeout =~ ^[1-9][0-9]*$ ]] || { echo "--request-timeout must be a positive integer" >&2; exit 2; }
[[ $max_retries =~ ^[0-9]+$ ]] || { echo "--max-retries must be a whole number" >&2; exit 2; }
IFS=, read -r -a mode_list <<<"$modes"
IFS=, read -r -a image_list <<<"$images"
((${#mode_list[@]})) || { echo "--modes is empty" >&2; exit 2; }
((${#image_list[@]})) || { echo "--images is empty" >&2; exit 2; }
for m in "${mode_list[@]}"; do [[ $m == idle || $m == loaded ]] || { echo "--modes: unknown mode '$m' (idle, loaded)" >&2; exit 2; }; done
for i in "${image_list[@]}"; do [[ $i == 1mp || $i == 16mp ]] || { echo "--images: unknown image '$i' (1mp, 16mp)" >&2; exit 2; }; done
for tool in curl jq vips vipsheader; do
  command -v "$tool" >/dev/null || { echo "needs $tool (apt-get install curl jq libvips-tools)" >&2; exit 2; }
done
[[ -x $zoomwarp_bin ]] || { echo "no zoomwarp binary at $zoomwarp_bin (build it, or --zoomwarp)" >&2; exit 2; }

# ---- process control: the server and the busy loops, all ended by the EXIT trap -----------------
work=""
zoomwarp_pid=""
busy_pids=()
stop_busy() {
  local pid
  for pid in "${busy_pids[@]}"; do kill -KILL "$pid" 2>/dev/null || true; wait "$pid" 2>/dev/null || true; done
  busy_pids=()
}
cleanup() {
  local rc=$?
  trap - EXIT INT TERM
  stop_busy
  stop_process "$zoomwarp_pid"
  if [[ -n $work && -d $work ]]; then
    if ((rc != 0)) && [[ -s $work/serve.log ]]; then log "zoomwarp serve's log:"; tail -n 20 "$work/serve.log" >&2; fi
    rm -rf "$work"
  fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
work=$(mktemp -d -t first-view.XXXXXX)

# ---- the images ------------------------------------------------------------------------------------
declare -A image_file image_desc
make_image() {  # make_image NAME PHOTO WIDTH HEIGHT: a centre crop, JPEG Q85
  local name=$1 photo=$corpus/$2 w=$3 h=$4 pw ph
  [[ -f $photo ]] || die "no photograph at $photo (--corpus, --small-photo, --large-photo)"
  pw=$(vipsheader -f width "$photo"); ph=$(vipsheader -f height "$photo")
  ((pw >= w && ph >= h)) || die "$photo is ${pw}x$ph: too small for a ${w}x$h crop"
  image_file[$name]="$work/$name.jpg"
  vips crop "$photo" "${image_file[$name]}[Q=85,strip]" $(((pw - w) / 2)) $(((ph - h) / 2)) "$w" "$h"
  image_desc[$name]="${w}x$h crop of $2, JPEG Q85, $(($(stat -c %s "${image_file[$name]}") / 1000)) kB"
}
for i in "${image_list[@]}"; do
  if [[ $i == 1mp ]]; then make_image 1mp "$small_photo" 1224 816; else make_image 16mp "$large_photo" 4896 3264; fi
  log "image $i: ${image_desc[$i]}"
done

# ---- requests ----------------------------------------------------------------------------------------
base=""
# timed_get URL: GETs URL until a 200, retrying a 503 after its Retry-After up to --max-retries
# times; sets got_status (the last status), got_seconds (from the first request to the last
# answer, waits included), got_retries and got_codes (the error codes of the retried answers).
timed_get() {
  local url=$1 t0=$EPOCHREALTIME seconds ra code
  got_retries=0
  got_codes=""
  while :; do
    got_status=""
    read -r got_status seconds < <(curl -sS -o "$work/body" -D "$work/head" -w '%{http_code} %{time_total}\n' \
      --max-time $((request_timeout + 60)) "$url" 2>"$work/curl.err" || true) || true
    if [[ ${got_status:-000} == 000 ]]; then
      cat "$work/curl.err" >&2
      kill -0 "$zoomwarp_pid" 2>/dev/null || die "zoomwarp serve exited (GET $url)"
      die "no answer to GET $url"
    fi
    if [[ $got_status != 503 ]] || ((got_retries >= max_retries)); then break; fi
    ra=$(sed -n 's/^[Rr]etry-[Aa]fter: *\([0-9]*\).*/\1/p' "$work/head" | head -n 1)
    code=$(jq -r '.error.code // "?"' "$work/body" 2>/dev/null || echo "?")
    got_codes+="${got_codes:+,}$code"
    got_retries=$((got_retries + 1))
    sleep "${ra:-1}"
  done
  got_seconds=$(awk -v a="$t0" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.3f\n", b - a }')
}

upload() {  # upload NAME ID -> sets upload_seconds
  local status="" seconds
  read -r status seconds < <(curl -sS -o "$work/body" -w '%{http_code} %{time_total}\n' --max-time 600 \
    --data-binary "@${image_file[$1]}" "$base/v1/images?id=$2" 2>"$work/curl.err" || true) || true
  [[ ${status:-000} == 201 ]] || { cat "$work/curl.err" "$work/body" >&2; die "upload of $1 as $2: status ${status:-none}, not 201"; }
  upload_seconds=$(printf '%.2f' "$seconds")
}

# GET /v1/methods: {"methods": [{"name", …}, …], "saliency": [kinds]}; its shape is checked.
method_names=()
saliency_kinds=()
read_methods() {
  curl -sSf -o "$work/methods.json" "$base/v1/methods" || die "GET /v1/methods failed"
  jq -e '(.methods | type == "array" and length > 0) and all(.methods[]; .name | type == "string")
         and (.saliency | type == "array" and length > 0)' "$work/methods.json" >/dev/null ||
    { head -c 2000 "$work/methods.json" >&2; die "GET /v1/methods: not {\"methods\": [{\"name\"…}], \"saliency\": […]}"; }
  mapfile -t method_names < <(jq -r '.methods[].name' "$work/methods.json")
  mapfile -t saliency_kinds < <(jq -r '.saliency[]' "$work/methods.json")
  if [[ -n $method_filter ]]; then
    local wanted=() m
    IFS=, read -r -a wanted <<<"$method_filter"
    for m in "${wanted[@]}"; do
      [[ " ${method_names[*]} " == *" $m "* ]] || die "--methods: the server has no method '$m' (it has: ${method_names[*]})"
    done
    method_names=("${wanted[@]}")
  fi
}

# ---- one run: a fresh server and store, every image × method × saliency -----------------------------
declare -A first later upload_time load_of
rows=()  # "image method saliency" in the order measured
run_mode() {  # run_mode idle|loaded
  local mode=$1 img m s id q z i times statuses med bad
  if [[ $mode == loaded ]]; then
    for ((i = 0; i < busy_count; i++)); do
      sh -c 'while :; do :; done' &
      busy_pids+=($!)
    done
    sleep 2
  fi
  load_of[$mode]=$(cut -d' ' -f1-3 /proc/loadavg)
  rm -rf "$work/store" "$work/serve.log"
  zoomwarp_serve "$zoomwarp_bin" "$work/store" "$work/serve.log" --open-writes --request-timeout "$request_timeout" ||
    die "zoomwarp serve did not start"
  base="http://127.0.0.1:$zoomwarp_port"
  log "$mode: zoomwarp serve (pid $zoomwarp_pid) on 127.0.0.1:$zoomwarp_port, load average ${load_of[$mode]}"
  read_methods
  log "$mode: methods ${method_names[*]}; saliency ${saliency_kinds[*]}"
  for img in "${image_list[@]}"; do
    if ((!fresh_upload)); then
      upload "$img" "$img"
      upload_time[$mode|$img]=$upload_seconds
      log "$mode: $img uploaded in $upload_seconds s"
    fi
    for m in "${method_names[@]}"; do
      local kinds=("${saliency_kinds[@]}")
      [[ $m == traditional ]] && kinds=("")
      for s in "${kinds[@]}"; do
        id=$img
        if ((fresh_upload)); then
          id="$img-$m${s:+-$s}"
          upload "$img" "$id"
          upload_time[$mode|$img]="${upload_time[$mode|$img]:-}${upload_time[$mode|$img]:+ }$upload_seconds"
        fi
        q="method=$m${s:+&saliency=$s}&w=$screen_w&h=$screen_h"
        timed_get "$base/v1/images/$id/viewport?$q&zoom=0"
        first[$mode|$img|$m|$s]="$got_seconds $got_status $got_retries ${got_codes:--}"
        times=(); statuses=()
        for z in "${later_zooms[@]}"; do
          timed_get "$base/v1/images/$id/viewport?$q&zoom=$z"
          times+=("$got_seconds")
          [[ $got_status == 200 && $got_retries == 0 ]] || statuses+=("z$z: $got_status${got_codes:+ after $got_retries retries ($got_codes)}")
        done
        med=$(printf '%s\n' "${times[@]}" | sort -g | awk '{ v[NR] = $1 } END { printf "%.0f\n", v[int((NR + 1) / 2)] * 1000 }')
        bad=$(IFS=';'; echo "${statuses[*]:-}")
        later[$mode|$img|$m|$s]="$med|$bad"
        [[ " ${rows[*]} " == *" $img/$m/$s "* ]] || rows+=("$img/$m/$s")
        log "$mode: $img $m ${s:-(none)}: first $(first_cell "$mode|$img|$m|$s"); later median $med ms${bad:+ ($bad)}"
      done
    done
  done
  stop_process "$zoomwarp_pid"
  zoomwarp_pid=""
  stop_busy
}

first_cell() {  # first_cell KEY -> "1.23 s, 200" / "31.2 s, 200 after 1 retry (analysis_pending)"
  local seconds status retries codes
  read -r seconds status retries codes <<<"${first[$1]}"
  local cell
  cell="$(printf '%.2f' "$seconds") s, $status"
  # The retried answers' codes, counted: "analysis_pending" or "2× deadline_exceeded, analysis_pending".
  codes=$(tr , '\n' <<<"$codes" | sort | uniq -c | sort -rn |
    awk '{ printf "%s%s%s", (NR > 1 ? ", " : ""), ($1 > 1 ? $1 "× " : ""), $2 }')
  ((retries == 0)) || cell+=" after $retries retr$( ((retries == 1)) && echo y || echo ies) ($codes)"
  echo "$cell"
}
later_cell() {
  local med bad
  IFS='|' read -r med bad <<<"${later[$1]}"
  echo "$med ms${bad:+ ($bad)}"
}

for mode in "${mode_list[@]}"; do run_mode "$mode"; done

# ---- report -------------------------------------------------------------------------------------------
{
  echo "First view against later views: ${screen_w}x$screen_h /viewport, first at zoom 0, later at zoom $(IFS=,; echo "${later_zooms[*]}") (median);"
  echo "zoomwarp serve --request-timeout $request_timeout, a fresh server and store per column group; $(nproc) cores;"
  echo "methods in GET /v1/methods order, $( ((fresh_upload)) && echo "each method and saliency on an upload of its own" ||
    echo "one upload per image (an analysis methods share is paid by the first that needs it)")."
  for mode in "${mode_list[@]}"; do
    echo -n "$mode: load average ${load_of[$mode]} at the start"
    [[ $mode == loaded ]] && echo -n " (with $busy_count busy loops)"
    echo -n "; uploads:"
    for img in "${image_list[@]}"; do echo -n " $img ${upload_time[$mode|$img]} s"; done
    echo
  done
  echo
  for img in "${image_list[@]}"; do echo "- $img: ${image_desc[$img]}"; done
  echo
  header="| image | method | saliency |"; rule="|---|---|---|"
  for mode in "${mode_list[@]}"; do header+=" $mode: first view (s, status) | $mode: later views |"; rule+="---|---:|"; done
  echo "$header"; echo "$rule"
  for row in "${rows[@]}"; do
    IFS=/ read -r img m s <<<"$row"
    line="| $img | $m | ${s:-–} |"
    for mode in "${mode_list[@]}"; do
      key="$mode|$img|$m|$s"
      if [[ $m == icaz && ${s:-default} == default ]]; then
        line+=" **$(first_cell "$key")** | $(later_cell "$key") |"
      else
        line+=" $(first_cell "$key") | $(later_cell "$key") |"
      fi
    done
    echo "$line"
  done
} >"$work/report.md"
echo
cat "$work/report.md"
if [[ -n $out_file ]]; then cp "$work/report.md" "$out_file"; log "written to $out_file"; fi
