// The oracle of the stored-tile tests: a stored JPEG tile read straight from its level file with
// libtiff (not through tiles/stored_tiles.h), and JPEG decoding that makes a crop's pixels
// comparable with the whole tile's.
#pragma once

#include <string>

#include "tiles/raster.h"

namespace zoomwarp::testing {

// complete_jpeg(JPEGTables, raw tile) of tile (tx, ty) of the tiled TIFF at `level_path`, at its
// stored (padded) size. Fails the test (and returns "") if the file cannot be read.
std::string stored_tile_jpeg(const std::string& level_path, int tx, int ty);

// `jpeg` decoded to RGB with chroma replicated, not interpolated (TurboJPEG's fast upsampling):
// each pixel then depends on its own blocks only, so a lossless crop of a tile decodes to exactly
// the crop of the tile's pixels. (Interpolating chroma looks at the neighbouring samples, which the
// crop's last column and row no longer have.)
tiles::Raster decode_jpeg_blockwise(const std::string& jpeg);

}  // namespace zoomwarp::testing
