#!/usr/bin/env bash
# Sets up, builds, ingests the bundled sample image and serves it on http://127.0.0.1:8080/.
# Environment variables ZOOMWARP_* configure the server (see `build/bin/zoomwarp serve --help`).
# It listens on loopback only, with --open-writes: anyone on this machine may upload and edit (the
# viewer shows its curator tools once any text is entered as its curator key). With ZOOMWARP_KEYS
# set, keys govern writes instead (and ZOOMWARP_HOST is honoured).
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/setup.sh
scripts/build.sh zoomwarp
export ZOOMWARP_STORE="${ZOOMWARP_STORE:-$PWD/store}"
if [ ! -e "$ZOOMWARP_STORE/images/boats_lake_sunset" ]; then
  build/bin/zoomwarp ingest samples/boats_lake_sunset.jpg --id boats_lake_sunset
fi
port="${ZOOMWARP_PORT:-8080}"
cat <<TXT

zoomwarp is starting on http://127.0.0.1:${port}/  (Ctrl-C stops it)
  images:    curl http://127.0.0.1:${port}/v1/images
  IIIF:      http://127.0.0.1:${port}/iiif/3/boats_lake_sunset/full/!800,800/0/default.jpg
  Deep Zoom: http://127.0.0.1:${port}/dzi/boats_lake_sunset.dzi
  manifest:  http://127.0.0.1:${port}/iiif/presentation/3/boats_lake_sunset/manifest  (IIIF Presentation 3: open it in Mirador or the Universal Viewer)
  metrics:   curl http://127.0.0.1:${port}/metrics

TXT
# Open writes only where nobody else can reach them: loopback, whatever ZOOMWARP_HOST says.
access=(--host 127.0.0.1 --open-writes)
if [ -n "${ZOOMWARP_KEYS:-}" ]; then access=(); fi
exec build/bin/zoomwarp serve "${access[@]}"
