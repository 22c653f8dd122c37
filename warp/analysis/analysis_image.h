// The analysis image of a version: the pyramid level whose long side is at most
// kSignificanceMaxSide (1024 px), read whole. Every map and every method's precomputation is made
// from it, in its pixels ("analysis pixels", `SignificanceMap::scale` per image pixel), so none
// grows with the image.
#pragma once

#include "tiles/pyramid_reader.h"
#include "tiles/raster.h"
#include "tiles/store.h"

namespace zoomwarp::warp {

// The pyramid level read_reduced_image reads: the first whose long side is at most
// kSignificanceMaxSide (the last level if none is). Its size is every saliency map's.
int analysis_level(const tiles::Manifest& manifest);

// Throws std::runtime_error when the pyramid cannot be read.
tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader);

}  // namespace zoomwarp::warp
