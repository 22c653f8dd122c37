// What the warp engine computes once per image version at ingest and keeps next to the pyramid,
// so that a view never touches full-resolution pixels: the significance map (≤ 1024 px, binary
// floats in significance.bin). The coarsest mesh is rebuilt from it in milliseconds and the
// forest is made lazily, so neither is stored.
#pragma once

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/significance.h"

namespace zoomwarp::warp {

inline constexpr const char* kSignificanceFile = "significance.bin";

// The pyramid level whose long side is at most kSignificanceMaxSide, read whole.
tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader);

// Computes the significance map of a (possibly still staged) image and writes it into its folder.
// Throws std::runtime_error if it cannot write.
void write_image_analysis(const tiles::ImageEntry& image);

// Reads the map back; throws std::runtime_error if missing or damaged.
SignificanceMap read_significance(const tiles::ImageEntry& image);

}  // namespace zoomwarp::warp
