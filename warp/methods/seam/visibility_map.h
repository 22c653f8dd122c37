// Seam carving's precomputation [Avidan07], as liblqr computes it: the visibility map of one axis
// records, for every pixel of the analysis image, when seam carving removes it. Removing k seams
// (the k cheapest 8-connected paths across the image, one after another, each at most 1 px
// sideways per line) keeps, on every line, exactly the pixels whose value is 0 (never removed) or
// greater than k — so one map answers every width from L − D to L, and the carving to a narrower
// width removes a superset of what a wider one removes (seams are nested).
//
// A horizontal map (seams run top to bottom, columns are removed) has lines = rows and positions
// = columns; a vertical one (seams run left to right, rows are removed) is stored transposed,
// lines = columns and positions = rows, so the two share the code below.
//
// Thread safety: plain functions on plain data; thread-safe.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tiles/raster.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct VisibilityMap {
  int length = 0;  // positions along a line: the analysis width for a horizontal map
  int lines = 0;   // lines across: the analysis height for a horizontal map
  int depth = 0;   // D: seams recorded; every line holds each of 1 … D exactly once
  std::vector<std::uint16_t> order;  // [line · length + position]: 0 never removed, v: by the v-th seam

  std::uint16_t at(int line, int position) const { return order[std::size_t(line) * length + position]; }
};

struct VisibilityMaps {
  VisibilityMap horizontal;  // removes columns: narrows the image
  VisibilityMap vertical;    // removes rows: lowers it
};

// The share of each axis recorded: D = floor(0.9 · L) seams, so carving can go down to a tenth of
// the side (narrower targets are carved to that floor and the rest scaled, SeamCarving).
inline constexpr int kRecordedSeamsPercent = 90;

// liblqr's bias factor for the saliency map (values in [0, 1]). liblqr adds factor · s / 2 to a
// pixel's energy and divides it by the carved side: at 1024 px a fully salient pixel gets ~0.5,
// the order of the gradient-norm energy on textured content, so saliency and texture both count.
// Calibrated by SeamBias's test (docs/algorithms.md, "seam"): at half width 29.9 % of the top-decile salient
// pixels are removed without a bias, 22.9 % with factor 100, 18.6 % with 1000, 18.3 % with
// 100 000 — past 1000 the bias only overrides the energy more.
inline constexpr int kSaliencyBiasFactor = 1000;

// Both maps of `image` (any channel count), with liblqr's gradient-norm energy
// (LQR_EF_GRAD_NORM), seams moving ≤ 1 px per line, no rigidity [Avidan07 §3], and `saliency`
// (resampled to the image when its size differs) added to the energy with `bias_factor` so that
// salient pixels are removed last [Guo09 §4.1 does the same for its seam-carving baseline].
// An axis liblqr cannot carve (a side of 1 px, a failing call) gets depth 0: not carvable.
VisibilityMaps compute_visibility_maps(const tiles::Raster& image, const SignificanceMap& saliency,
                                       int bias_factor = kSaliencyBiasFactor);

// Empty when `map` has the format above (sizes consistent, every line holding 1 … depth exactly
// once and nothing above depth); else what is wrong.
std::string check_visibility_map(const VisibilityMap& map);

// The carving of one axis by k seams (0 ≤ k ≤ depth): per line, the kept positions in
// increasing order — every line keeps length − k of them.
struct CarveTable {
  int kept = 0;
  int lines = 0;
  std::vector<std::uint16_t> positions;  // [line · kept + j]

  const std::uint16_t* line(int l) const { return positions.data() + std::size_t(l) * kept; }
  std::size_t bytes() const { return positions.size() * sizeof(std::uint16_t); }
};

// Throws std::invalid_argument for k outside [0, depth]. O(length · lines).
CarveTable carve(const VisibilityMap& map, int k);

}  // namespace zoomwarp::warp
