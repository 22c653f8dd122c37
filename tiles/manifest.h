// What the store knows about one published image version: its size, its pyramid, where it came
// from. Written as manifest.json next to the pyramid levels; immutable once published.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

#include "tiles/jpeg_tiles.h"

namespace zoomwarp::tiles {

struct Manifest {
  std::string id;
  std::string version;     // unique per publish; part of every ETag and cache key
  int width = 0;           // full resolution, after EXIF orientation was applied
  int height = 0;
  int channels = 3;        // stored channels: 3 (RGB) or 4 (RGBA, straight alpha)
  int levels = 0;          // pyramid levels; level k is ceil(width / 2^k) wide, the last is 1×1
  int tile_size = 256;     // square tiles of the stored levels
  std::string compression; // TIFF compression of the stored levels (level_file.h)
  JpegTileFormat jpeg;      // compression "jpeg": the tiles' quality and chroma subsampling
  std::int64_t created_ms = 0;  // Unix time of publishing, milliseconds
  std::string source_format;    // "jpeg", "png", "tiff", "webp"
  int source_bits = 8;          // bits per sample of the source (stored as 8)
  int source_channels = 3;
  int source_orientation = 1;   // EXIF orientation that was applied
  std::int64_t source_bytes = 0;
  // SHA-256 of the source file's bytes, 64 lower-case hex digits, when the ingest was given it
  // (IngestOptions::source_sha256): `zoomwarp ingest` skips a file whose bytes are already
  // published under its id. Empty when unknown: uploads, manifests written before it existed. An
  // edit publishes from the old manifest, so it stays: the edited image still comes from them.
  std::string source_sha256;
  // Readable only with a curator key or a signed URL (api/README.md, "Private images"). Set at
  // upload; edits publish from the old manifest, so it carries over; a re-upload states it again.
  // Manifests written before it existed have no "private" member and are public.
  bool is_private = false;

  bool has_alpha() const { return channels == 4; }
  int level_width(int k) const { return int((std::int64_t(width) + (1LL << k) - 1) >> k); }
  int level_height(int k) const { return int((std::int64_t(height) + (1LL << k) - 1) >> k); }
};

// Number of levels of a pyramid halving (rounding up) from w×h down to 1×1:
// ceil(log2(max(w, h))) + 1, the same count as a Deep Zoom pyramid.
int pyramid_levels(int width, int height);

std::string manifest_to_json(const Manifest& m);
// Throws std::runtime_error on malformed or inconsistent input.
Manifest manifest_from_json(std::string_view json);

}  // namespace zoomwarp::tiles
