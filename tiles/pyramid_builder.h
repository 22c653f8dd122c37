// Ingest, step one: decode a source image and write its multi-resolution pyramid.
//
// The source is streamed in strips of scanlines; each strip becomes one row of tiles of level 0
// and is halved (2×2 box, rounding sizes up) into level 1, which feeds level 2, and so on down to
// 1×1. The tiles are compressed on PyramidOptions::threads threads and written in order
// (strip_pipeline.h), so the files do not depend on the thread count. Memory is about two strips
// per level, never the whole image — except for sources with an EXIF rotation, which are decoded
// whole (as 8-bit, never float) to be reoriented. Each level is its own tiled TIFF (see
// tiles/README.md for why).
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "tiles/ingest_error.h"
#include "tiles/level_file.h"

namespace zoomwarp::tiles {

struct PyramidOptions {
  int tile_size = 256;
  // TIFF compression of the levels (tiles/README.md, "Tile compression per source"): "auto" is
  // JPEG tiles for a lossy source (JPEG, lossy WebP) and zip:1 for the others; "jpeg" is JPEG
  // tiles for every source; or one lossless method for every source ("zip:1" … "zip:9", "zip",
  // "lzw", "none"). Sources with alpha are stored with zip:1 when JPEG is asked for: JPEG has no
  // alpha channel.
  std::string compression = "auto";
  // JPEG tiles' quality, at most: a JPEG source of a lower quality is stored at its own
  // (source_compression.h), and with its own chroma subsampling.
  int jpeg_quality = 90;
  // Threads compressing tiles, the calling thread (which decodes and halves) included; the files
  // are byte for byte the same whatever the count.
  int threads = 1;
};

struct SourceLimits {
  std::uint64_t max_pixels = 1'000'000'000;  // width × height, checked from the header
  int max_dimension = 1 << 20;
  // What decoding may hold at once: most sources are read in strips or tiles, well under this;
  // one that must be decoded whole (a JPEG 2000 OpenJPEG cannot read by tiles, an image turned
  // upright by its EXIF orientation) and would need more is refused before anything is decoded.
  std::uint64_t max_decode_bytes = 4ull << 30;
};

struct PyramidInfo {
  int width = 0, height = 0;  // after orientation
  int channels = 3;           // stored: 3 or 4
  int levels = 0;
  std::string source_format;
  int source_bits = 8;
  int source_channels = 3;
  int source_orientation = 1;
  LevelCompression compression;  // what the levels were stored with
};

// Fraction of the work done, 0…1, never decreasing; called from the ingesting thread only.
using ProgressFn = std::function<void(double)>;

// File name of pyramid level k inside an image version's folder.
std::string level_filename(int k);

// Writes level_0.tif … level_{n-1}.tif into the existing folder `out_dir`. Throws IngestError;
// on error the caller discards out_dir. Bad input (an unsupported format, a size over the limits,
// a file its decoder cannot open) is refused before anything is written.
PyramidInfo build_pyramid(const std::string& source_path, const std::string& out_dir,
                          const PyramidOptions& options, const SourceLimits& limits,
                          const ProgressFn& progress = {});

}  // namespace zoomwarp::tiles
