#!/usr/bin/env bash
# Copies what the zoomwarp binary needs at run time into DESTDIR, at the paths it has on this
# machine: every shared object the dynamic loader resolves for it (`ldd`: the whole NEEDED
# closure, the loader included), each as its real file plus the link, named as the loader looks it
# up (the SONAME; the interpreter path), that leads to it; and the files of
# deploy/runtime-files.txt, which no NEEDED entry names (data files, and objects loaded with
# dlopen, which bring their own ldd closure). The image's runtime stage is debian:bookworm-slim
# with this tree copied over it (deploy/Dockerfile), and deploy/rootfs-test.sh builds and runs its
# root the same way: the libraries are the builder's own, so the binary runs with the ones it was
# linked against.
#
#   deploy/runtime-closure.sh [--base ROOT] BINARY DESTDIR
#
#   --base ROOT   leave out what the root file system at ROOT (the runtime base image) already has:
#                 a regular file with the same bytes, a symbolic link with the same target. Both
#                 roots must share this machine's layout (the same Debian release, merged /usr).
#
# Fails (exit 1, naming what) when ldd cannot resolve an object, when BINARY is not dynamically
# linked, or when a listed file is missing. DESTDIR must not exist or be empty. Prints one
# line: what was copied and what the base already had.
set -Eeuo pipefail
export LC_ALL=C

SELF=$(readlink -f "${BASH_SOURCE[0]}")
readonly FILE_LIST=${SELF%/*}/runtime-files.txt

die() {
  printf 'runtime-closure: %s\n' "$*" >&2
  exit 1
}

usage() {
  sed -n '2,/^set -Eeuo/{/^set/d;s/^# \{0,1\}//;p}' "$SELF"
}

BASE='' DEST=''
COPIED_BYTES=0 COPIED_FILES=0 KEPT_BYTES=0 KEPT_FILES=0 REPLACING_FILES=0

# shared_objects ELF...: the absolute paths ldd resolves for each ELF file, the loader's own path
# included; dies listing every object that is "not found" (the loader would refuse to start it).
shared_objects() {
  local binary
  for binary in "$@"; do resolve_needed "$binary"; done | sort -u
}

resolve_needed() {
  local binary=$1 out
  out=$(ldd "$binary" 2>&1) || die "ldd $binary failed: $out"
  local missing
  missing=$(awk '/=> not found/ { print $1 }' <<<"$out")
  [[ -z $missing ]] || die "ldd $binary: not found: $(tr '\n' ' ' <<<"$missing")"
  # "NAME => /path (0x...)" for a NEEDED object, "/path (0x...)" for the loader, "NAME (0x...)"
  # for the kernel's vDSO, which has no file.
  awk '$2 == "=>" && $3 ~ /^\// { print $3; next } $1 ~ /^\// { print $1 }' <<<"$out" |
    grep . || die "ldd $binary lists no shared object: $out"
}

# data_files: the paths of runtime-files.txt, one per line, '#' to the end of a line a comment.
data_files() {
  [[ -f $FILE_LIST ]] || die "missing $FILE_LIST"
  awk '
    { sub(/#.*/, "") }
    NF == 0 { next }
    NF > 1 || $1 !~ /^\// { printf "%s:%d: one absolute path per line\n", FILENAME, FNR > "/dev/stderr"; bad = 1; next }
    { print $1 }
    END { exit bad }' "$FILE_LIST" || die "malformed $FILE_LIST"
}

# base_has_file REAL: the base root has the regular file REAL with the same bytes. Links inside
# the base are never followed: they point into the base, not into this machine.
base_has_file() {
  local there=$BASE$1
  [[ -n $BASE && -f $there && ! -L $there ]] && cmp -s "$1" "$there"
}

# base_has_link LINK TARGET: the base root has LINK, a symbolic link to TARGET.
base_has_link() {
  local there=$BASE$1
  [[ -n $BASE && -L $there && $(readlink "$there") == "$2" ]]
}

mib() { awk -v b="$1" 'BEGIN { printf "%.1f", b / 1048576 }'; }

# copy_file REAL: the regular file REAL into DESTDIR, mode and times kept, unless the base has it.
copy_file() {
  local real=$1 bytes
  bytes=$(stat -c %s "$real")
  if base_has_file "$real"; then
    KEPT_BYTES=$((KEPT_BYTES + bytes)) KEPT_FILES=$((KEPT_FILES + 1))
    return
  fi
  # Another version of the file in the base (a package updated on one side only) is replaced, so
  # that the binary runs with the libraries it was linked against, glibc's parts all of one version.
  if [[ -n $BASE && -f $BASE$real ]]; then REPLACING_FILES=$((REPLACING_FILES + 1)); fi
  mkdir -p "$DEST${real%/*}"
  cp -p "$real" "$DEST$real"
  COPIED_BYTES=$((COPIED_BYTES + bytes)) COPIED_FILES=$((COPIED_FILES + 1))
}

# copy_path PATH: the file PATH finally names (every link resolved) and, when PATH is a link, one
# link at PATH's own name, in PATH's real folder, straight to that file. Chains through other
# folders (/etc/alternatives for liblapack.so.3) are not reproduced: the loader needs the name
# only. Paths are taken with their folders resolved, so /lib/x/libz.so.1 lands in /usr/lib/x on
# a merged-/usr root instead of replacing the /lib link with a folder.
copy_path() {
  local path=$1 real dir link
  real=$(readlink -e "$path") || die "$path does not exist"
  [[ -f $real ]] || die "$path is not a regular file"
  copy_file "$real"
  dir=$(readlink -e "${path%/*}")
  link=$dir/${path##*/}
  [[ $link != "$real" ]] || return 0
  local target
  target=$(realpath --relative-to="$dir" "$real")
  base_has_link "$link" "$target" && return
  mkdir -p "$DEST$dir"
  ln -sfn "$target" "$DEST$link"
}

main() {
  case "${1:-}" in
    -h | --help) usage; exit 0 ;;
    --base)
      [[ $# -ge 2 ]] || die "--base needs a folder"
      BASE=$(readlink -e "$2") || die "no base root at $2"
      [[ $BASE != / ]] || die "--base / would leave out everything"
      shift 2
      ;;
  esac
  [[ $# -eq 2 ]] || die "usage: runtime-closure.sh [--base ROOT] BINARY DESTDIR (see --help)"
  local binary=$1
  [[ -x $binary ]] || die "no executable at $binary"
  DEST=$(readlink -m "$2")
  [[ ! -e $DEST || -z $(ls -A "$DEST") ]] || die "$DEST is not empty"

  local list objects=() files=() loaded=() path
  list=$(data_files) || exit 1
  [[ -z $list ]] || mapfile -t files <<<"$list"
  for path in "${files[@]}"; do
    [[ -e $path ]] || die "$path (from $FILE_LIST) is missing on this machine"
    if [[ ${path##*/} == *.so* ]]; then loaded+=("$path"); fi
  done
  list=$(shared_objects "$binary" "${loaded[@]}") || exit 1
  mapfile -t objects <<<"$list"
  mkdir -p "$DEST"
  for path in "${objects[@]}" "${files[@]}"; do copy_path "$path"; done
  printf 'runtime-closure: %d shared objects, %d listed files: copied %d files (%s MiB)' \
    "${#objects[@]}" "${#files[@]}" "$COPIED_FILES" "$(mib "$COPIED_BYTES")"
  if [[ -n $BASE ]]; then
    printf ' (%d of them replacing a different version in the base), %d files (%s MiB) already in %s' \
      "$REPLACING_FILES" "$KEPT_FILES" "$(mib "$KEPT_BYTES")" "$BASE"
  fi
  printf '\n'
}

main "$@"
