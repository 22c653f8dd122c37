#!/usr/bin/env bash
# Installs every build and test dependency of zoomwarp from Debian 12 packages (and the npm
# packages of the browser tests), non-interactively. Safe to run again: it installs only what is
# missing. This is the only install step anyone, CI included, needs.
#
#   scripts/setup.sh               everything: build, tests, benchmarks, browser tests
#   scripts/setup.sh --build-only  only what building the zoomwarp binary needs (-DBUILD_TESTING=OFF):
#                                  the builder stage of deploy/Dockerfile, which should not carry
#                                  a browser, Node, nginx or test libraries
set -euo pipefail
cd "$(dirname "$0")/.."

build_only=0
for arg in "$@"; do
  case "$arg" in
    --build-only) build_only=1 ;;
    -h | --help) sed -n '2,/^set /s/^# \{0,1\}//p' "$0"; exit 0 ;;  # the comment above
    *) echo "setup: unknown argument '$arg' (see --help)" >&2; exit 2 ;;
  esac
done

# Build of the zoomwarp binary: compiler, CMake, and the libraries the design fixes (README "Built with")
# (libssl-dev: libcrypto, SHA-256 and constant-time comparison of API keys).
# openimageio-tools too: OpenImageIO's CMake package fails unless the tools it lists exist.
build_pkgs=(
  build-essential cmake ninja-build pkg-config
  libopenimageio-dev openimageio-tools
  libeigen3-dev libsuitesparse-dev libcgal-dev libboost-dev
  nlohmann-json3-dev libturbojpeg0-dev libpng-dev libwebp-dev libavif-dev libjxl-dev libssl-dev
  libopencv-imgproc-dev libopencv-objdetect-dev
  libssl-dev
  # pyramid levels written by tiles/level_file.cc: libtiff directly, tiles compressed by ISA-L
  # (zip:1) and libdeflate (other zip levels)
  libtiff-dev libdeflate-dev libisal-dev
  # sources' ICC profiles converted to sRGB at ingest (tiles/icc_to_srgb.h)
  liblcms2-dev
  # JPEG 2000 sources decoded tile by tile, in bounded memory (tiles/jpeg2000_rows.h)
  libopenjp2-7-dev
  # the S3 store's client (tiles/s3_client.cc): libcurl (OpenSSL flavour) signs and sends requests,
  # expat parses S3's XML answers
  libcurl4-openssl-dev libexpat1-dev
  # seam carving (warp/methods/seam/): liblqr's headers include GLib's, which its package does not pull in
  liblqr-1-0-dev libglib2.0-dev
  # the face cascade the binary loads at run time; the container image copies it from the builder
  # (deploy/runtime-files.txt)
  opencv-data
)
# Working on it: git, and the test and benchmark libraries; LBFGSpp (header-only) is the reference
# polyfem's own L-BFGS is tested against (tests/unit/polyfem_lbfgs_test.cc).
# libcurl: the S3 test fixture (tests/support/swift_s3.cc) signs its requests with it.
dev_pkgs=(git ca-certificates libgtest-dev libgmock-dev libbenchmark-dev liblbfgspp-dev libcurl4-openssl-dev)
# Tests and benchmarks: a browser for the viewer tests, Node for driving it, nginx and wrk to
# measure against and to front the replicas (tests/cluster/), curl and jq for the scripts,
# PyYAML for the deployment files' test (tests/deploy/). The S3 tests' object store
# (tests/support/swift_s3/): OpenStack Swift with its s3api middleware (python3-swift, which pulls
# in python3-xattr and eventlet; the server scripts need no swift-* package) and the memcached its
# tempauth needs; the data folder must have user xattrs, which start.sh checks.
test_pkgs=(chromium nodejs npm nginx-light wrk curl jq procps python3-yaml python3-swift memcached
  # the source formats' tests make JPEG 2000, HEIF/AVIF and TIFF variants with Debian's own
  # encoders and decode them with its own decoders (tests/unit/source_formats_test.cc)
  libopenjp2-tools libheif-examples libtiff-tools
  # High-Throughput JPEG 2000 codestreams (OpenJPH's ojph_compress), which OpenJPEG 2.5 decodes
  openjph-tools
  # issue 41's squash measures (tests/bench/squash.py): an independent saliency model in numpy, and
  # libvips' attention smart crop, what users pick instead of a warp
  python3-numpy python3-pil libvips-tools)
pkgs=("${build_pkgs[@]}")
if [ "$build_only" -eq 0 ]; then pkgs+=("${dev_pkgs[@]}" "${test_pkgs[@]}"); fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then sudo_cmd=(sudo); fi

missing=()
for p in "${pkgs[@]}"; do
  # nodejs/npm may come from elsewhere (a newer Node on the PATH is fine).
  case "$p" in nodejs) command -v node >/dev/null && continue ;; npm) command -v npm >/dev/null && continue ;; esac
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ "${#missing[@]}" -gt 0 ]; then
  echo "setup: installing ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  "${sudo_cmd[@]}" apt-get update -q
  "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
else
  echo "setup: Debian packages already installed"
fi

# npm packages of the browser tests (OpenSeadragon, Mirador, the Universal Viewer, the IIIF
# Presentation 3 schema validator, playwright-core driving Debian's chromium).
if [ "$build_only" -eq 0 ] && [ -f tests/browser/package.json ]; then
  if [ ! -d tests/browser/node_modules ] || [ tests/browser/package-lock.json -nt tests/browser/node_modules ]; then
    (cd tests/browser && npm ci --no-audit --no-fund --loglevel=error)
    touch tests/browser/node_modules
  fi
fi
echo "setup: done"
