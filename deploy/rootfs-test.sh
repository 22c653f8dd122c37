#!/usr/bin/env bash
# Proves the container image without Docker: builds the runtime root file system deploy/Dockerfile
# describes (Debian 12 minbase, slimmed like debian:bookworm-slim, plus what
# deploy/runtime-closure.sh copies: the binary's shared objects and the data files it reads), adds
# the zoomwarp binary, the uid/gid 10001 user and its store, then runs the server in it as that
# user and checks what a container would be asked: /healthz, ingests of every source format with a
# viewport of each, face detection, a mesh, an upload, a clean exit on SIGTERM. Prints the size of
# the root in parts, its largest shared objects and the time each phase took. See deploy/ROOTFS.md.
#
#   deploy/rootfs-test.sh [ZOOMWARP_BINARY]        # default: $ZOOMWARP_BINARY, then build/bin/zoomwarp
#
# Environment:
#   ROOTFS_TEST_CACHE            cache folder (default build-rootfs/rootfs-cache); the cached base
#                                layer is rebuilt only when its inputs change (suite, mirrors)
#   ROOTFS_TEST_MIRROR           Debian mirror (default: the host's apt sources for bookworm)
#   ROOTFS_TEST_SECURITY_MIRROR  security mirror (default: the host's for bookworm-security)
#   ROOTFS_TEST_REBUILD=1        rebuild the cached base layer (e.g. to pick up security updates)
#   ROOTFS_TEST_KEEP=1           keep the assembled root (CACHE/run/root) for inspection
#
# Exit status: 0 pass, 1 failure, 77 skipped (not root: chroot, mounts and namespaces need it).
#
# Needs root, debootstrap, util-linux (unshare, flock), curl, oiiotool (openimageio-tools) and the
# libraries the binary was linked with (the closure is copied from this machine, as the image's is
# from its builder), with opencv-data's face cascade.
# The script re-runs itself inside new mount and PID namespaces (unshare), so every mount it
# makes and every process it starts disappears when that inner run ends, however it ends (a
# SIGKILL included); the assembled root is removed on exit and, if a kill left one behind, at the
# start of the next run.
set -Eeuo pipefail
# One locale for sort, awk and $EPOCHREALTIME (whose decimal separator follows LC_NUMERIC).
export LC_ALL=C

readonly SUITE=bookworm
readonly APP_USER=zoomwarp APP_UID=10001 APP_GID=10001
readonly STORE=/var/lib/zoomwarp
readonly APP_BINARY=/usr/local/bin/zoomwarp
readonly SAMPLE=boats_lake_sunset.jpg SAMPLE_ID=boats UPLOAD_ID=boats-upload
# Every source format ingest accepts (tiles/source_format.h), each ingested in the root and viewed:
# the sample JPEG itself, the bundled RGBA PNG, and the JPEG written as TIFF and WebP by oiiotool.
readonly ALPHA_SAMPLE=pano_grossmugl_field_4to1.png
readonly FORMAT_IDS=(boats pano-png boats-tiff boats-webp)
# Face detection (warp/saliency/significance.h): the portrait ingested with the image's cascade and
# with none; the significance maps must differ where the face was found.
readonly FACE_SAMPLE=astronaut_portrait.png FACE_ID=astronaut NO_FACE_ID=astronaut-no-cascade
readonly VIEW_QUERY='zoom=0.5&w=480&h=360' VIEW_SIZE=480x360
# The key file the server reads (ZOOMWARP_KEYS), as a Kubernetes Secret mounts it; its curator
# key (uploads) and admin key (/readyz details) are made per run.
readonly KEYS_FILE=/etc/zoomwarp/keys
random_key() { head -c 24 /dev/urandom | od -An -tx1 | tr -d ' \n'; }
CURATOR_KEY=$(random_key) ADMIN_KEY=$(random_key)
readonly CURATOR_KEY ADMIN_KEY
readonly ROOT_PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
# Part of every cache key: bump it when this script changes how it builds a cached layer.
readonly CACHE_FORMAT=2

SELF=$(readlink -f "${BASH_SOURCE[0]}")
REPO=$(cd "$(dirname "$SELF")/.." && pwd)
readonly SELF REPO
readonly CLOSURE=$REPO/deploy/runtime-closure.sh FILE_LIST=$REPO/deploy/runtime-files.txt

# ---------------------------------------------------------------------------------------------
# Messages and timing

say() { printf 'rootfs-test: %s\n' "$*"; }

die() {
  printf 'rootfs-test: FAIL: %s\n' "$*" >&2
  exit 1
}

# Unexpected command failures (set -e) get a message naming the command, not a silent exit.
# Only the top-level shell reports, so a failure inside $(...) is not reported twice.
on_error() {
  local status=$1 line=$2 command=$3
  if [[ $BASH_SUBSHELL -eq 0 ]]; then
    printf "rootfs-test: FAIL: line %s: '%s' exited with %s\n" "$line" "$command" "$status" >&2
  fi
}

PHASE_NAMES=() PHASE_SECONDS=() PHASE_NOTES=()
PHASE_STARTED='' PHASE_NOTE=''

# phase NAME FUNCTION [ARGS...]: runs FUNCTION and records its wall time; FUNCTION may set
# PHASE_NOTE (e.g. "cached") for the summary.
phase() {
  local name=$1
  shift
  say "== $name"
  PHASE_NOTE=''
  PHASE_STARTED=$EPOCHREALTIME
  "$@"
  PHASE_NAMES+=("$name")
  PHASE_SECONDS+=("$(elapsed_since "$PHASE_STARTED")")
  PHASE_NOTES+=("$PHASE_NOTE")
}

elapsed_since() { awk -v a="$1" -v b="$EPOCHREALTIME" 'BEGIN { printf "%.1f", b - a }'; }

print_phases() {
  local i total=0
  printf '\n%-10s %9s  %s\n' phase seconds note
  for i in "${!PHASE_NAMES[@]}"; do
    printf '%-10s %9s  %s\n' "${PHASE_NAMES[$i]}" "${PHASE_SECONDS[$i]}" "${PHASE_NOTES[$i]}"
  done
  total=$(elapsed_since "$RUN_STARTED")
  printf '%-10s %9s\n' total "$total"
}

# ---------------------------------------------------------------------------------------------
# Configuration (resolved outside the namespaces, passed in through the environment)

usage() {
  sed -n '2,/^set -Eeuo/{/^set/d;s/^# \{0,1\}//;p}' "$SELF"
}

resolve_config() {
  [[ $# -le 1 ]] || die "one argument at most (the zoomwarp binary); see --help"
  local binary=${1:-${ZOOMWARP_BINARY:-$REPO/build/bin/zoomwarp}}
  [[ -x $binary ]] || die "no executable zoomwarp binary at $binary (build it first: scripts/build.sh)"
  ROOTFS_TEST_BINARY=$(readlink -f "$binary")
  ROOTFS_TEST_CACHE=$(readlink -m "${ROOTFS_TEST_CACHE:-$REPO/build-rootfs/rootfs-cache}")
  # The mount bookkeeping below reads /proc/self/mountinfo, which escapes blanks; keep paths plain.
  [[ $ROOTFS_TEST_CACHE != *[[:space:]]* ]] || die "ROOTFS_TEST_CACHE must not contain blanks"
  [[ $ROOTFS_TEST_CACHE != / ]] || die "ROOTFS_TEST_CACHE must not be /"
  ROOTFS_TEST_MIRROR=${ROOTFS_TEST_MIRROR:-$(host_apt_uri "$SUITE" http://deb.debian.org/debian)}
  ROOTFS_TEST_SECURITY_MIRROR=${ROOTFS_TEST_SECURITY_MIRROR:-$(host_apt_uri "$SUITE-security" http://deb.debian.org/debian-security)}
  export ROOTFS_TEST_BINARY ROOTFS_TEST_CACHE ROOTFS_TEST_MIRROR ROOTFS_TEST_SECURITY_MIRROR
  local sample
  for sample in "$SAMPLE" "$ALPHA_SAMPLE" "$FACE_SAMPLE"; do
    [[ -f $REPO/samples/$sample ]] || die "missing sample $REPO/samples/$sample"
  done
}

# host_apt_uri SUITE DEFAULT: the first URI the host's apt sources use for SUITE (deb822 .sources
# files or one-line sources.list), so the root is fetched through the same mirror as the host's
# own packages; DEFAULT when none is found.
host_apt_uri() {
  local suite=$1 fallback=$2 found=''
  local deb822=() oneline=()
  shopt -s nullglob
  deb822=(/etc/apt/sources.list.d/*.sources)
  oneline=(/etc/apt/sources.list /etc/apt/sources.list.d/*.list)
  shopt -u nullglob
  if [[ ${#deb822[@]} -gt 0 ]]; then
    # One stanza per paragraph; a new file also ends a stanza (FNR == 1).
    found=$(awk -v suite="$suite" '
      function flush() {
        if (!done && deb && wanted && enabled && uri != "") { print uri; done = 1 }
        deb = wanted = 0; enabled = 1; uri = ""
      }
      BEGIN { enabled = 1 }
      FNR == 1 { flush() }
      /^[[:space:]]*$/ { flush(); next }
      /^#/ { next }
      tolower($1) == "types:"   { for (i = 2; i <= NF; i++) if ($i == "deb") deb = 1 }
      tolower($1) == "uris:"    { uri = $2 }
      tolower($1) == "suites:"  { for (i = 2; i <= NF; i++) if ($i == suite) wanted = 1 }
      tolower($1) == "enabled:" { enabled = tolower($2) != "no" }
      END { flush() }' "${deb822[@]}")
  fi
  if [[ -z $found ]]; then
    local f
    for f in "${oneline[@]}"; do
      [[ -f $f ]] || continue
      # deb [options] URI SUITE COMPONENTS...
      found=$(awk -v suite="$suite" '
        $1 == "deb" && !done {
          i = 2
          if ($i ~ /^\[/) { while (i < NF && $i !~ /\]$/) i++; i++ }
          if ($(i + 1) == suite) { print $i; done = 1 }
        }' "$f")
      [[ -z $found ]] || break
    done
  fi
  [[ -n $found ]] || found=$fallback
  printf '%s\n' "${found%%$'\n'*}"
}

# apt's own proxy setting, if the host has one, as the variables debootstrap (wget) and the
# chroot's apt-get read: the root is then fetched the way the host fetches its packages.
export_host_apt_proxy() {
  local http='' https=''
  eval "$(apt-config shell http Acquire::http::Proxy https Acquire::https::Proxy)"
  if [[ -z ${http_proxy:-} && -n $http && $http != DIRECT ]]; then export http_proxy=$http; fi
  if [[ -z ${https_proxy:-} && -n $https && $https != DIRECT ]]; then export https_proxy=$https; fi
}

require_root_and_tools() {
  if [[ $(id -u) -ne 0 ]]; then
    say "SKIP: needs root (debootstrap, chroot, mounts and namespaces); run it with sudo"
    exit 77
  fi
  local tool missing=()
  for tool in debootstrap unshare flock chroot curl oiiotool apt-config awk ldd cmp; do
    command -v "$tool" >/dev/null || missing+=("$tool")
  done
  [[ ${#missing[@]} -eq 0 ]] ||
    die "missing ${missing[*]} (apt-get install debootstrap util-linux curl openimageio-tools)"
}

# ---------------------------------------------------------------------------------------------
# File-system safety: this script removes only folders it made inside the cache, never through a
# mount point (a bind-mounted /dev inside a root must not be emptied by rm -rf).

mounts_under() {
  awk -v d="$1" '$5 == d || index($5, d "/") == 1 { print $5 }' /proc/self/mountinfo | sort -r
}

unmount_under() {
  local target
  while read -r target; do
    umount "$target" 2>/dev/null || umount --lazy "$target"
  done < <(mounts_under "$1")
}

remove_tree() {
  local dir=$1
  [[ $dir == "$ROOTFS_TEST_CACHE"/* ]] || die "refusing to remove $dir: not inside $ROOTFS_TEST_CACHE"
  [[ -e $dir || -L $dir ]] || return 0
  [[ -z $(mounts_under "$dir") ]] || die "refusing to remove $dir: file systems are mounted under it"
  rm -rf --one-file-system -- "$dir"
}

# ---------------------------------------------------------------------------------------------
# Outside the namespaces: lock, start the inner run, clean up whatever happens to it.

NS_PID=''

outer_cleanup() {
  local status=$?
  if [[ -n $NS_PID ]] && kill -0 "$NS_PID" 2>/dev/null; then
    # unshare --kill-child turns this into SIGKILL for the inner run, and the kernel tears down
    # its PID namespace (every process) and mount namespace (every mount) with it.
    kill -KILL "$NS_PID" 2>/dev/null || true
    wait "$NS_PID" 2>/dev/null || true
  fi
  # The root's mounts lived only in the inner mount namespace: from here it is plain folders.
  if [[ -z ${ROOTFS_TEST_KEEP:-} ]]; then
    remove_tree "$ROOTFS_TEST_CACHE/run"
  else
    say "kept $ROOTFS_TEST_CACHE/run/root (ROOTFS_TEST_KEEP); rerunning removes it"
  fi
  exit "$status"
}

take_cache_lock() {
  mkdir -p "$ROOTFS_TEST_CACHE"
  exec {LOCK_FD}>"$ROOTFS_TEST_CACHE/lock"
  if ! flock --nonblock "$LOCK_FD"; then
    say "waiting for another run using $ROOTFS_TEST_CACHE"
    flock --timeout 3600 "$LOCK_FD" || die "another run kept $ROOTFS_TEST_CACHE/lock for an hour"
  fi
}

outer_main() {
  case "${1:-}" in
    -h | --help) usage; exit 0 ;;
  esac
  require_root_and_tools
  resolve_config "$@"
  export_host_apt_proxy
  take_cache_lock
  trap outer_cleanup EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM HUP
  # A run killed before its EXIT trap leaves its root behind; it is stale by now (we hold the lock).
  remove_tree "$ROOTFS_TEST_CACHE/run"
  # --fork: the inner run is PID 1 of the new PID namespace; --kill-child: it dies with unshare.
  _ROOTFS_TEST_INNER=1 unshare --mount --propagation private --pid --fork --mount-proc --kill-child \
    -- "$SELF" &
  NS_PID=$!
  local status=0
  wait "$NS_PID" || status=$?
  NS_PID=''
  exit "$status" # the EXIT trap removes the root
}

# ---------------------------------------------------------------------------------------------
# The cached layer: CACHE/base (debootstrap minbase, slimmed). It is built in base.partial and
# renamed when complete; base.key records its inputs, so a changed input rebuilds it and an
# interrupted build is never mistaken for a layer.

layer_is_current() {
  local name=$1 key=$2 dir=$ROOTFS_TEST_CACHE/$1
  [[ -z ${ROOTFS_TEST_REBUILD:-} && -d $dir && -f $dir.key && "$(<"$dir.key")" == "$key" ]]
}

publish_layer() {
  local name=$1 key=$2 dir=$ROOTFS_TEST_CACHE/$1
  rm -f "$dir.key"
  remove_tree "$dir"
  mv "$dir.partial" "$dir"
  printf '%s\n' "$key" >"$dir.key"
}

base_key() {
  printf 'format=%s suite=%s variant=minbase mirror=%s security=%s' \
    "$CACHE_FORMAT" "$SUITE" "$ROOTFS_TEST_MIRROR" "$ROOTFS_TEST_SECURITY_MIRROR"
}

# in_root ROOT COMMAND...: COMMAND inside ROOT as root, with the root's PATH (not the host's).
in_root() {
  local root=$1
  shift
  PATH=$ROOT_PATH chroot "$root" "$@"
}

build_base_layer() {
  local key partial=$ROOTFS_TEST_CACHE/base.partial log=$ROOTFS_TEST_CACHE/debootstrap.log
  key=$(base_key)
  if layer_is_current base "$key"; then PHASE_NOTE=cached; return; fi
  remove_tree "$partial"
  mkdir -p "$ROOTFS_TEST_CACHE/debs"
  say "debootstrap --variant=minbase $SUITE from $ROOTFS_TEST_MIRROR (log: $log)"
  # --cache-dir keeps the downloaded .debs, so a rebuild (new mirror, ROOTFS_TEST_REBUILD) is local.
  if ! debootstrap --variant=minbase --components=main --cache-dir="$ROOTFS_TEST_CACHE/debs" \
    "$SUITE" "$partial" "$ROOTFS_TEST_MIRROR" >"$log" 2>&1; then
    tail -n 20 "$log" >&2
    die "debootstrap failed (full log: $log)"
  fi
  unmount_under "$partial" # debootstrap unmounts its /proc and /sys itself; this is for a failure
  slim_like_docker_image "$partial"
  drop_apt_caches "$partial"
  write_apt_sources "$partial"
  # shellcheck disable=SC2016 # a dpkg-query format, not a shell expansion
  in_root "$partial" dpkg-query -W -f='${Package}\n' >"$ROOTFS_TEST_CACHE/base.packages"
  publish_layer base "$key"
  PHASE_NOTE="debootstrap, $(wc -l <"$ROOTFS_TEST_CACHE/base.packages") packages"
}

# debian:bookworm-slim, the Dockerfile's runtime base, is minbase with documentation, manuals and
# translations left out by dpkg (debuerreotype's "slim" variant). The same dpkg configuration, and
# the same files removed, make the sizes measured here the image's.
slim_like_docker_image() {
  local root=${1:?}
  cat >"$root/etc/dpkg/dpkg.cfg.d/docker" <<'EOF'
# As debian:bookworm-slim: files which are normally unnecessary in containers are excluded.
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/groff/*
path-exclude /usr/share/info/*
path-exclude /usr/share/linda/*
path-exclude /usr/share/lintian/*
path-exclude /usr/share/locale/*
path-exclude /usr/share/man/*
EOF
  find "$root/usr/share/doc" -mindepth 1 ! -type d ! -name copyright -delete
  find "$root/usr/share/doc" -mindepth 1 -type d -empty -delete
  local d
  for d in groff info linda lintian locale man; do
    if [[ -d $root/usr/share/$d ]]; then
      find "$root/usr/share/$d" -mindepth 1 -delete
    fi
  done
}

# Package lists, downloaded .debs and apt's binary caches: none of them is in the image (the
# Dockerfile removes the lists, Debian images' apt configuration the rest), so none is measured.
drop_apt_caches() {
  local root=${1:?}
  rm -rf "$root/var/lib/apt/lists/"* "$root/var/cache/apt/"*.bin
  find "$root/var/cache/apt/archives" -name '*.deb' -delete
}

# The apt sources of debian:bookworm-slim (bookworm, bookworm-updates, bookworm-security), on the
# mirrors this run uses.
write_apt_sources() {
  local root=${1:?}
  rm -f "$root/etc/apt/sources.list"
  cat >"$root/etc/apt/sources.list.d/debian.sources" <<EOF
Types: deb
URIs: $ROOTFS_TEST_MIRROR
Suites: $SUITE $SUITE-updates
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg

Types: deb
URIs: $ROOTFS_TEST_SECURITY_MIRROR
Suites: $SUITE-security
Components: main
Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg
EOF
}

# ---------------------------------------------------------------------------------------------
# The closure (CACHE/run/closure), the assembled root (CACHE/run/root: the base layer with the
# closure copied over it) and the container around it

RUN_DIR='' CLOSURE_DIR='' ROOT='' SERVER_LOG='' SERVER_PID='' PORT=''

# The Dockerfile builder's last step: deploy/runtime-closure.sh, against the base layer as the
# builder runs it against debian:bookworm-slim, so only what the base lacks is copied. Not cached:
# it depends on the binary and on this machine's libraries, and takes seconds.
build_closure() {
  [[ ! -e $RUN_DIR ]] || die "$RUN_DIR exists (the outer run removes it first)"
  mkdir -p "$RUN_DIR"
  drop_package_layer
  local summary
  summary=$("$CLOSURE" --base "$ROOTFS_TEST_CACHE/base" "$ROOTFS_TEST_BINARY" "$CLOSURE_DIR") ||
    die "deploy/runtime-closure.sh failed"
  say "$summary"
  PHASE_NOTE=${summary#runtime-closure: }
  PHASE_NOTE=${PHASE_NOTE%, * already in *}
}

# Before the closure, this script cached the root with Debian's runtime packages installed (about
# 720 MiB, with the .debs it downloaded); a cache from then holds them for nothing.
drop_package_layer() {
  local old
  for old in runtime runtime.partial apt-archives; do remove_tree "$ROOTFS_TEST_CACHE/$old"; done
  rm -f "$ROOTFS_TEST_CACHE/runtime.key" "$ROOTFS_TEST_CACHE/apt.log"
}

# What a container runtime gives a process: a fresh /proc and a minimal /dev (a tmpfs with the
# usual character devices), read-only since nothing here needs to write either.
mount_container_fs() {
  local root=${1:?} dev
  mount -t proc -o ro,nosuid,nodev,noexec proc "$root/proc"
  mount -t tmpfs -o mode=0755,nosuid,noexec,size=64k tmpfs "$root/dev"
  for dev in null zero full random urandom tty; do
    touch "$root/dev/$dev"
    mount --bind "/dev/$dev" "$root/dev/$dev"
  done
  ln -s /proc/self/fd "$root/dev/fd"
  ln -s /proc/self/fd/0 "$root/dev/stdin"
  ln -s /proc/self/fd/1 "$root/dev/stdout"
  ln -s /proc/self/fd/2 "$root/dev/stderr"
  mount -o remount,ro "$root/dev"
}

# As the Dockerfile's runtime stage: the closure copied over the base, the loader's cache rebuilt
# (ldconfig), the user and group with fixed ids, the store folder it owns (mode 0750), the binary
# in /usr/local/bin.
assemble_root() {
  cp -a --reflink=auto "$ROOTFS_TEST_CACHE/base" "$ROOT"
  cp -a --reflink=auto "$CLOSURE_DIR/." "$ROOT/"
  in_root "$ROOT" ldconfig
  in_root "$ROOT" groupadd --system --gid "$APP_GID" "$APP_USER"
  in_root "$ROOT" useradd --system --uid "$APP_UID" --gid "$APP_USER" --home-dir "$STORE" \
    --no-create-home --shell /usr/sbin/nologin "$APP_USER"
  install -d -o "$APP_UID" -g "$APP_GID" -m 0750 "$ROOT$STORE"
  install -m 0755 "$ROOTFS_TEST_BINARY" "$ROOT$APP_BINARY"
  mount_container_fs "$ROOT"
  set_app_command
}

# "${APP[@]}" [NAME=VALUE...] COMMAND...: COMMAND in the root the way the image's USER, WORKDIR and
# ENV run it: uid and gid 10001 without supplementary groups, in the store, with only the image's
# environment (no variable of this shell leaks in). An array, not a function, so that a command
# started with & is the server itself (chroot and env exec), not a subshell around it.
APP=()
set_app_command() {
  APP=(chroot --userspec="$APP_UID:$APP_GID" --groups='' "$ROOT"
    /usr/bin/env -i --chdir="$STORE" PATH="$ROOT_PATH" HOME="$STORE" ZOOMWARP_STORE="$STORE")
}

# ingest_in_root FILE ID [NAME=VALUE...]: `zoomwarp ingest` of the root's /tmp/FILE as uid 10001,
# with the variables given added to the image's environment; its messages go to RUN_DIR/ingest.log.
ingest_in_root() {
  local file=$1 want=$2 id log=$RUN_DIR/ingest.log
  shift 2
  if ! id=$("${APP[@]}" "$@" zoomwarp ingest "/tmp/$file" --id "$want" --quiet 2>>"$log"); then
    tail -n 5 "$log" >&2
    die "zoomwarp ingest of $file failed inside the root (log: $log)"
  fi
  [[ $id == "$want" ]] || die "zoomwarp ingest of $file printed '$id', expected '$want'"
}

# The sources, one per format (FORMAT_IDS, in that order), and the portrait for face detection,
# all decoded by the root's libraries; the TIFF and the WebP are written by this machine's oiiotool,
# at half the JPEG's size (1280×800) to keep the ingests short.
ingest_samples() {
  local tmp=$ROOT/tmp
  install -m 0644 "$REPO/samples/$SAMPLE" "$REPO/samples/$ALPHA_SAMPLE" "$REPO/samples/$FACE_SAMPLE" "$tmp/"
  oiiotool -q "$tmp/$SAMPLE" --resize 1280x800 -o "$tmp/boats.tif" -o "$tmp/boats.webp" ||
    die "oiiotool could not write the TIFF and WebP samples"
  chmod 0644 "$tmp/boats.tif" "$tmp/boats.webp"
  [[ $(oiiotool --info "$tmp/$ALPHA_SAMPLE") == *", 4 channel,"* ]] || die "$ALPHA_SAMPLE has no alpha channel"
  local files=("$SAMPLE" "$ALPHA_SAMPLE" boats.tif boats.webp) i
  for i in "${!FORMAT_IDS[@]}"; do ingest_in_root "${files[$i]}" "${FORMAT_IDS[$i]}"; done
  ingest_in_root "$FACE_SAMPLE" "$FACE_ID"
  ingest_in_root "$FACE_SAMPLE" "$NO_FACE_ID" ZOOMWARP_FACE_CASCADE=/no-such-cascade.xml
  PHASE_NOTE="zoomwarp ingest as uid $APP_UID: JPEG, PNG (RGBA), TIFF, WebP; portrait with and without cascade"
}

# The image's CMD (serve), on loopback and a port the kernel picks (read from the 'listening'
# log line), instead of the image's 0.0.0.0:8080; with a key file readable by its group only.
start_server() {
  install -d -m 0755 "$(dirname "$ROOT$KEYS_FILE")"
  printf 'rootfs-test curator %s\nrootfs-test-admin admin %s\n' "$CURATOR_KEY" "$ADMIN_KEY" >"$ROOT$KEYS_FILE"
  chown "0:$APP_GID" "$ROOT$KEYS_FILE"
  chmod 0640 "$ROOT$KEYS_FILE"
  "${APP[@]}" ZOOMWARP_HOST=127.0.0.1 ZOOMWARP_PORT=0 ZOOMWARP_KEYS="$KEYS_FILE" zoomwarp serve >"$SERVER_LOG" 2>&1 &
  SERVER_PID=$!
  local deadline=$((SECONDS + 30))
  until PORT=$(sed -n 's/.*"msg":"listening".*"port":\([0-9]*\).*/\1/p' "$SERVER_LOG") && [[ -n $PORT ]]; do
    kill -0 "$SERVER_PID" 2>/dev/null || server_failed "zoomwarp serve exited before listening"
    ((SECONDS < deadline)) || server_failed "zoomwarp serve did not listen within 30 s"
    sleep 0.1
  done
  check_server_identity
  expect_get /healthz 200 application/json "$RUN_DIR/healthz.json"
  PHASE_NOTE="port $PORT, /healthz 200"
}

server_failed() {
  say "server log ($SERVER_LOG, kept with ROOTFS_TEST_KEEP=1):"
  tail -n 20 "$SERVER_LOG" >&2 || true
  die "$1"
}

# The point of the exercise: the server runs as 10001:10001 without groups, inside the root.
check_server_identity() {
  local ids
  ids=$(awk '$1 == "Uid:" || $1 == "Gid:" { $1 = ""; printf "%s;", $0 } $1 == "Groups:" { print NF - 1 }' \
    "/proc/$SERVER_PID/status")
  local want=" $APP_UID $APP_UID $APP_UID $APP_UID; $APP_GID $APP_GID $APP_GID $APP_GID;0"
  [[ $ids == "$want" ]] || die "server ids (real/effective/saved/fs uid; gid; groups) are '$ids', expected '$want'"
  [[ $(readlink "/proc/$SERVER_PID/root") == "$ROOT" ]] || die "server is not running inside $ROOT"
}

# http METHOD PATH OUT [CURL ARGS...]: prints "STATUS CONTENT-TYPE"; the body goes to OUT.
http() {
  local method=$1 path=$2 out=$3
  shift 3
  # No response prints "000 " (curl says why on stderr), which the caller reports as a mismatch.
  curl -sS --max-time 30 -X "$method" -o "$out" -w '%{http_code} %{content_type}' "$@" \
    "http://127.0.0.1:$PORT$path" || true
}

# expect_get PATH STATUS TYPE OUT: GET PATH answers STATUS with a Content-Type starting with TYPE.
expect_get() {
  expect_http GET "$@"
}

expect_http() {
  local method=$1 path=$2 status=$3 type=$4 out=$5 got
  shift 5
  got=$(http "$method" "$path" "$out" "$@")
  [[ ${got%% *} == "$status" && ${got#* } == "$type"* ]] ||
    server_failed "$method $path: got '$got', expected '$status $type' (body: $(head -c 300 "$out" 2>/dev/null))"
  say "$method $path -> $got"
}

# json_has FILE TEXT...: each TEXT occurs in the JSON in FILE once blanks are removed (enough
# for these bodies, none of whose strings has a blank; '"a":[[' means a non-empty array of arrays).
json_has() {
  local file=$1 text compact
  shift
  compact=$(tr -d ' \n\t' <"$file")
  for text in "$@"; do
    [[ $compact == *"$text"* ]] || die "$file has no $text: ${compact:0:300}"
  done
}

# expect_image PATH TYPE OUT SIZE: GET PATH is a TYPE image that decodes, every pixel of it
# (oiiotool --printstats reads them all, not only the header), to SIZE (WIDTHxHEIGHT).
expect_image() {
  local path=$1 type=$2 out=$3 want=$4 size
  expect_get "$path" 200 "$type" "$out"
  size=$(oiiotool -q "$out" --printstats --echo '{TOP.width}x{TOP.height}' 2>&1 | tail -n 1) ||
    die "$path does not decode: $size"
  [[ $size == "$want" ]] || die "$path is $size, expected $want"
  say "$path decodes to $size"
}

check_requests() {
  local out=$RUN_DIR
  expect_get /readyz 200 application/json "$out/readyz.json"
  expect_get "/v1/images/$SAMPLE_ID" 200 application/json "$out/image.json"
  json_has "$out/image.json" "\"id\":\"$SAMPLE_ID\"" "\"status\":\"ready\""

  local id
  for id in "${FORMAT_IDS[@]}"; do
    expect_image "/v1/images/$id/viewport?$VIEW_QUERY" image/jpeg "$out/viewport-$id.jpg" "$VIEW_SIZE"
  done
  # IIIF, in the two other output formats.
  expect_image "/iiif/3/pano-png/full/480,/0/default.png" image/png "$out/iiif.png" 480x120
  expect_image "/iiif/3/boats-tiff/0,0,640,400/480,/0/default.webp" image/webp "$out/iiif.webp" 480x300
  check_face_detection

  expect_get "/v1/images/$SAMPLE_ID/mesh?$VIEW_QUERY" 200 application/json "$out/mesh.json"
  json_has "$out/mesh.json" '"vertices":[[' '"triangles":[[' '"tiles":[{'
  # The mesh's first tile must be servable too: the viewer fetches exactly these URLs.
  local tile
  tile=$(grep -o '"url":"/dzi/[^"]*"' "$out/mesh.json" | head -n 1 | sed 's/"url":"\(.*\)"/\1/')
  expect_get "$tile" 200 image/jpeg "$out/tile.jpg"

  check_image_healthcheck

  # An upload makes the server itself (uid 10001) write a new image into the store; only with
  # the curator key of the key file it read (a container never starts open to writes).
  expect_http POST "/v1/images?id=$UPLOAD_ID" 401 application/json "$out/upload-nokey.json" \
    --data-binary "@$REPO/samples/$SAMPLE" -H 'Content-Type: application/octet-stream'
  expect_http POST "/v1/images?id=$UPLOAD_ID" 201 application/json "$out/upload.json" \
    --data-binary "@$REPO/samples/$SAMPLE" -H 'Content-Type: application/octet-stream' \
    -H "Authorization: Bearer $CURATOR_KEY"
}

# The cascade is in the root and loads (/readyz's details, for an admin key, say "on"), and finds
# the face: the portrait's significance map differs from the one ingested without a cascade.
check_face_detection() {
  local out=$RUN_DIR
  expect_get /readyz 200 application/json "$out/readyz-admin.json" -H "Authorization: Bearer $ADMIN_KEY"
  json_has "$out/readyz-admin.json" '"face_detection":"on"'
  expect_get "/v1/images/$FACE_ID/significance.png" 200 image/png "$out/faces.png"
  expect_get "/v1/images/$NO_FACE_ID/significance.png" 200 image/png "$out/no-faces.png"
  ! cmp -s "$out/faces.png" "$out/no-faces.png" ||
    die "the portrait's significance map is the same with and without the cascade: no face found in the root"
  say "face detection on; the portrait's significance map shows the face"
}

# The Dockerfile's HEALTHCHECK, `zoomwarp health` (the slim image has no curl), run in the root as
# the container runtime would, with the port the server listens on. Binaries built before that
# command existed are reported, not failed.
check_image_healthcheck() {
  if ! "${APP[@]}" zoomwarp health --help >/dev/null 2>&1; then
    say "HEALTHCHECK not checked: this zoomwarp has no 'health' command"
    return
  fi
  "${APP[@]}" ZOOMWARP_PORT="$PORT" zoomwarp health || server_failed "HEALTHCHECK 'zoomwarp health' failed in the root"
  say "HEALTHCHECK zoomwarp health -> exit 0"
}

# SIGTERM, as `docker stop` sends: the server drains and must exit 0 within its drain timeout.
stop_server() {
  kill -TERM "$SERVER_PID"
  local deadline=$((SECONDS + 40)) status=0
  while kill -0 "$SERVER_PID" 2>/dev/null && ((SECONDS < deadline)); do sleep 0.1; done
  kill -0 "$SERVER_PID" 2>/dev/null && server_failed "zoomwarp serve still running 40 s after SIGTERM"
  wait "$SERVER_PID" || status=$?
  SERVER_PID=''
  [[ $status -eq 0 ]] || server_failed "zoomwarp serve exited with $status after SIGTERM, expected 0"
  PHASE_NOTE="SIGTERM, exit 0"
}

# ---------------------------------------------------------------------------------------------
# Report: the size of each part of the root, and its largest shared objects

SIZE_REPORT=''

# KiB as MiB, one decimal; a few KiB either side of zero print as 0.0, not -0.0.
mib() { awk -v k="$1" 'BEGIN { m = k / 1024; if (m > -0.05 && m < 0.05) m = 0; printf "%.1f", m }'; }

du_kib() { du -sxk "$@" | awk '{ s += $1 } END { print s }'; }

# data_paths: the data files of runtime-files.txt (not its shared objects), as paths in the root.
data_paths() { sed 's/#.*//' "$FILE_LIST" | awk 'NF && $1 !~ /\.so/ { print $1 }'; }

# KiB and path of each regular file of the closure that is not a data file, largest first.
closure_objects() {
  local data
  data=$(data_paths)
  (cd "$CLOSURE_DIR" && find . -type f -printf '%k\t/%P\n') |
    awk -F'\t' -v data="$data" 'BEGIN { n = split(data, d, "\n"); for (i = 1; i <= n; i++) skip[d[i]] = 1 }
      !($2 in skip)' | sort -k1,1nr
}

# The closure's objects are counted apart from the base: those it adds, and those replacing a
# different version of a file the base has (the size they add or take away).
measure_root() {
  local base=$ROOTFS_TEST_CACHE/base kib path
  local added=0 added_count=0 replaced=0 replaced_count=0 data=0 binary total
  while IFS=$'\t' read -r kib path; do
    if [[ -f $base$path && ! -L $base$path ]]; then
      replaced=$((replaced + kib - $(du_kib "$base$path"))) replaced_count=$((replaced_count + 1))
    else
      added=$((added + kib)) added_count=$((added_count + 1))
    fi
  done < <(closure_objects)
  while read -r path; do data=$((data + $(du_kib "$ROOT$path"))); done < <(data_paths)
  binary=$(du_kib "$ROOT$APP_BINARY")
  total=$(du_kib "$ROOT")
  local rest=$((total - $(du_kib "$base") - added - replaced - data - binary))
  SIZE_REPORT=$(
    printf '%-56s %9s\n' 'root file system (du)' MiB
    printf '%-56s %9s\n' "debootstrap minbase, slimmed" "$(mib "$(du_kib "$base")")"
    printf '%-56s %9s\n' "+ shared objects it lacks ($added_count files)" "$(mib "$added")"
    printf '%-56s %9s\n' "+ shared objects replacing its own ($replaced_count files)" "$(mib "$replaced")"
    printf '%-56s %9s\n' "+ data files (runtime-files.txt)" "$(mib "$data")"
    printf '%-56s %9s\n' "+ $APP_BINARY" "$(mib "$binary")"
    printf '%-56s %9s\n' "+ links, folders, ld.so.cache, user, store" "$(mib "$rest")"
    printf '%-56s %9s\n' "whole root" "$(mib "$total")"
    printf '\n%-56s %9s\n' "largest shared objects of $((added_count + replaced_count)) copied" MiB
    # awk reads the whole list: head would end the pipeline with SIGPIPE, a failure under pipefail.
    closure_objects | awk -F'\t' 'NR <= 15 { printf "%-56s %9.1f\n", $2, $1 / 1024 }'
  )
  PHASE_NOTE="$(mib "$total") MiB"
}

# ---------------------------------------------------------------------------------------------
# Inside the namespaces

inner_cleanup() {
  local status=$?
  if [[ -n $SERVER_PID ]] && kill -0 "$SERVER_PID" 2>/dev/null; then
    kill -KILL "$SERVER_PID" 2>/dev/null || true
  fi
  # Leaving the namespaces would drop these mounts anyway; unmounting keeps the order visible.
  unmount_under "$ROOTFS_TEST_CACHE"
  exit "$status"
}

inner_main() {
  trap inner_cleanup EXIT
  trap 'exit 130' INT
  trap 'exit 143' TERM HUP
  RUN_STARTED=$EPOCHREALTIME
  RUN_DIR=$ROOTFS_TEST_CACHE/run CLOSURE_DIR=$ROOTFS_TEST_CACHE/run/closure
  ROOT=$ROOTFS_TEST_CACHE/run/root SERVER_LOG=$ROOTFS_TEST_CACHE/run/server.log
  say "binary $ROOTFS_TEST_BINARY"
  say "cache $ROOTFS_TEST_CACHE, mirrors $ROOTFS_TEST_MIRROR $ROOTFS_TEST_SECURITY_MIRROR"
  phase base build_base_layer
  phase closure build_closure
  phase assemble assemble_root
  phase measure measure_root
  phase ingest ingest_samples
  phase start start_server
  phase requests check_requests
  phase stop stop_server
  printf '\n%s\n' "$SIZE_REPORT"
  print_phases
  say "PASS"
}

trap 'on_error $? $LINENO "$BASH_COMMAND"' ERR
if [[ ${_ROOTFS_TEST_INNER:-} == 1 ]]; then
  inner_main
else
  outer_main "$@"
fi
