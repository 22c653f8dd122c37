// Deep Zoom (DZI), the tile convention of OpenSeadragon and Seadragon: level 0 is 1×1 pixel and
// each level doubles the previous one, rounding up; tiles are TileSize pixels plus Overlap pixels
// shared with each neighbour. Our pyramid halves the same way, so DZI level L is stored level
// levels-1-L and a tile is a plain rectangle of one stored level, never resampled.
#pragma once

#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "tiles/manifest.h"
#include "tiles/raster.h"

namespace zoomwarp::api {

struct DziLayout {
  int tile_size = 254;  // 254 + 2 × 1 overlap = 256-pixel interior tiles
  int overlap = 1;
};

// The .dzi XML descriptor; `format` is the tile extension it advertises.
std::string dzi_descriptor(const tiles::Manifest& m, const DziLayout& layout, std::string_view format);

struct DziTile {
  int store_level = 0;  // pyramid level to read
  tiles::Rect rect;     // pixels of that level
};

// "{col}_{row}.{ext}", the last path segment of a tile URL; nullopt if malformed.
struct DziTileName {
  int col = 0, row = 0;
  std::string extension;
};
std::optional<DziTileName> parse_dzi_tile_name(std::string_view name);

// The pixels of tile (col, row) at DZI level `level`, or nullopt if there is no such tile.
std::optional<DziTile> dzi_tile(const tiles::Manifest& m, const DziLayout& layout, int level,
                                int col, int row);

// The DZI level whose resolution matches `magnification` screen pixels per full-resolution
// pixel: the coarsest one that is still at least that fine (so a client never magnifies a tile
// it could have had sharper).
int dzi_level_for(const tiles::Manifest& m, double magnification);

// The tiles of DZI level `level` that cover the full-resolution rectangle [u0, u1] × [v0, v1].
struct DziTileRef {
  int level = 0, col = 0, row = 0;
};
std::vector<DziTileRef> dzi_tiles_covering(const tiles::Manifest& m, const DziLayout& layout, int level, double u0,
                                           double v0, double u1, double v1);

}  // namespace zoomwarp::api
