// What a source's own compression says about how to store its pyramid (tiles/README.md,
// "Tile compression per source"): a lossy source (JPEG, lossy WebP, lossy JPEG 2000, HEIF, AVIF)
// gets JPEG tiles, and a JPEG
// source's tiles are never made at a higher quality than the source's own — storing a quality-75
// photograph at 90 would only keep its artefacts more exactly, at 1.6× the bytes.
// Pure functions of the file's first bytes; safe on any thread.
#pragma once

#include <optional>
#include <string>

#include "tiles/jpeg_tiles.h"

namespace zoomwarp::tiles {

struct SourceCompression {
  // JPEG, WebP whose image is a VP8 (not VP8L) bitstream, JPEG 2000 with the irreversible 9-7
  // wavelet, HEIF and AVIF.
  bool lossy = false;
  // For a JPEG source: its luma quantisation table's IJG quality (exact for libjpeg's, vips' and
  // most encoders' tables, the nearest for a camera's own) and its chroma subsampling.
  std::optional<JpegTileFormat> jpeg;
};

// `format` is sniff_image_file()'s answer for `path`. A header that cannot be read gives
// {lossy: format is "jpeg"} without `jpeg`; the decoder refuses a damaged source later anyway.
SourceCompression source_compression(const std::string& path, const std::string& format);

// The IJG quality (1…100) whose scaled Annex K luma table is nearest to `table` (64 values in
// natural order): the sum of absolute differences, ties to the higher quality.
int ijg_quality_of(const unsigned short (&table)[64]);

}  // namespace zoomwarp::tiles
