// method=patch's patches [Lin13 §III-B]: the analysis image cut into colour-homogeneous regions
// by Felzenszwalb–Huttenlocher graph-based segmentation [Felzenszwalb04], then the small and the
// similar ones merged, as [Lin13 Fig. 3] shows.
//
//   segment_graph   [Felzenszwalb04 §4]: the 8-neighbour pixel graph of the image smoothed by a
//                   Gaussian (σ), edge weights the Euclidean RGB distance; edges in increasing
//                   weight join two components when the weight is at most both components'
//                   internal difference plus k/|C|; then components under min_size pixels join
//                   a neighbour (the paper's post-processing, weakest edge first);
//   merge_patches   [Lin13 §III-B] on patch mean colours: a patch under min_fraction of the image
//                   joins the adjacent patch of nearest colour; then adjacent patches whose mean
//                   colours are closer than merge_distance (Euclidean RGB, 0–255: [Lin13] names no
//                   space, ours) merge, closest pair first, until no such pair is left.
//
// Deterministic (ties broken by pixel order). Thread safety: pure functions.
#pragma once

#include <array>
#include <vector>

#include "tiles/raster.h"

namespace zoomwarp::warp {

struct Patches {
  int width = 0, height = 0;
  int count = 0;
  std::vector<int> label;                         // per pixel (row-major), 0 … count − 1
  std::vector<int> size;                          // pixels per patch
  std::vector<std::array<double, 3>> mean_colour;  // per patch, RGB in 0–255 (grey: three equal)
};

struct SegmentationOptions {
  double sigma = 0.8;            // Gaussian smoothing before the graph [Felzenszwalb04 §5]
  double k = 500;                // the scale of observation: larger k, larger components
  int min_size = 50;             // components below this many pixels are joined (ours: [Lin13] gives none)
  double min_fraction = 1e-4;    // patches below 0.01 % of the image join their nearest neighbour [Lin13]
  double merge_distance = 20;    // adjacent patches closer than this in mean RGB merge [Lin13]
};

// Felzenszwalb–Huttenlocher alone (no merging). An empty image gives no patches.
Patches segment_graph(const tiles::Raster& image, const SegmentationOptions& options = {});

// The merging of [Lin13 §III-B] on `patches` (made by segment_graph on `image`), renumbered
// compactly in order of each patch's first pixel.
Patches merge_patches(const Patches& patches, const SegmentationOptions& options = {});

// segment_graph then merge_patches: the patches method=patch uses.
Patches segment_patches(const tiles::Raster& image, const SegmentationOptions& options = {});

// Whether patches a and b share a pixel edge or corner (8-neighbourhood), for tests and merging.
std::vector<std::vector<int>> patch_adjacency(const Patches& patches);

}  // namespace zoomwarp::warp
