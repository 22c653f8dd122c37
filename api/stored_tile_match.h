// Which requests are exactly one stored tile, so that the stored JPEG tile can be sent as it is
// (tiles/stored_tiles.h) instead of decoding and encoding (api/README.md, "Stored tiles sent as
// they are"). Pure functions of the request's plan and the manifest.
#pragma once

#include <optional>

#include "api/deepzoom.h"
#include "api/iiif.h"
#include "tiles/encode.h"
#include "tiles/manifest.h"

namespace zoomwarp::api {

// Tile (tx, ty) of stored level `level`.
struct StoredTileRef {
  int level = 0, tx = 0, ty = 0;
  bool operator==(const StoredTileRef&) const = default;
};

// The stored tile an IIIF request is, or nullopt. It is one when the image has JPEG tiles, the
// answer is a JPEG in colour (quality default or color) without rotation or mirroring, and the
// decode path (tiles::PyramidReader::read_scaled) would copy exactly the pixels of one stored tile
// and resample nothing: at the level it reads for the plan's shrink, the level pixels covering the
// region are one whole tile (clipped by the image's edge) and the output size is that tile's size.
// In full-resolution terms: region x,y multiples of tile_size·2^k, w,h = tile_size·2^k or up to the
// image's edge, size = region / 2^k. The answer is then the stored pixels, not encoded again.
std::optional<StoredTileRef> iiif_stored_tile(const tiles::Manifest& m, const IiifPlan& plan);

// The stored tile a Deep Zoom tile is, or nullopt: JPEG tiles, a jpg request, and a layout whose
// grid is the stored one (TileSize = the stored tile size, Overlap 0: --dzi-tile-size 256
// --dzi-overlap 0). The default layout, 254 + 1 overlap, never is.
std::optional<StoredTileRef> dzi_stored_tile(const tiles::Manifest& m, const DziLayout& layout, const DziTile& tile,
                                             tiles::ImageFormat format);

}  // namespace zoomwarp::api
