// Whole-raster pixel operations used to answer requests: orientation, colour quality, alpha.
// One operation per function, plain data in and out.
#pragma once

#include <cstdint>

#include "tiles/raster.h"

namespace zoomwarp::tiles {

// Mirrors left–right.
Raster mirror_horizontally(const Raster& in);

// Rotates clockwise by 0, 90, 180 or 270 degrees.
Raster rotate_clockwise(const Raster& in, int degrees);

// Luma (Rec. 709 weights), keeping alpha: RGB -> grey, RGBA -> grey+alpha.
Raster to_grey(const Raster& in);

// Black or white per pixel (luma ≥ 128 is white), keeping alpha.
Raster to_bitonal(const Raster& in);

// Composites straight alpha over a solid background; channels 2 -> 1, 4 -> 3; others unchanged.
Raster flatten_alpha(const Raster& in, std::uint8_t background = 255);

}  // namespace zoomwarp::tiles
