// The resolution seams are carved at: the analysis image (long side ≤ 1024 px) reduced to a long
// side of at most kSeamMaxSide. liblqr pays a pass over the image per seam, and the seams recorded
// are 0.9 of the carved side: the precomputation grows with the long side cubed (both maps of a
// 1024×768 analysis image: 4.6 s CPU, at 512 px 0.5 s). A kept position then stands for a strip
// at most twice as wide (SeamCarving renders it from full resolution either way); seam's compare
// metrics moved ≤ 2 % from 1024 px, as at 384 px (docs/ingest.md, "Compact analysis files
// (issue 28)").
//
// Thread safety: plain functions on plain data; thread-safe.
#pragma once

#include "tiles/raster.h"
#include "warp/methods/seam/visibility_map.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

inline constexpr int kSeamMaxSide = 512;

struct SeamMapSize {
  int width = 0, height = 0;
};

// The maps' size for an analysis image of width × height: its aspect, the long side at most
// kSeamMaxSide (rounded, each side ≥ 1); the analysis size itself when that is no larger.
SeamMapSize seam_map_size(int width, int height);

// compute_visibility_maps on `analysis` and `saliency` area-averaged to seam_map_size.
VisibilityMaps compute_seam_maps(const tiles::Raster& analysis, const SignificanceMap& saliency);

// Whether `maps` were made for an analysis image of width × height: at seam_map_size, or at the
// analysis size itself (seam.<saliency>.bin written before the maps were reduced).
bool seam_maps_fit(const VisibilityMaps& maps, int width, int height);

}  // namespace zoomwarp::warp
