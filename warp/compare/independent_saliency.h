// A saliency model no method here optimises, to judge the methods by (issue 41: "a measure the
// method does not optimise"): spectral residual [Hou07] alone, on a thumbnail whose long side is
// 128 px (never enlarged) — no gradient, no faces, no curator regions, another resolution than the significance
// the methods warp by (warp/saliency/significance.h: gradient × spectral residual on 64×64).
//
//   A = log |F(I)|,  R = A − mean₃ₓ₃(A),  S = G_σ=3 ∗ |F⁻¹(exp(R + i·arg F(I)))|²,  normalised to [0, 1].
//
// tests/bench/squash.py computes the same in numpy, so the figures of a running server and of
// `zoomwarp compare` are the same measure. Plain function; thread-safe.
#pragma once

#include "tiles/raster.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

inline constexpr int kIndependentSaliencySide = 128;

// `image` is the whole image at any reduced resolution (RGB, RGBA, grey); `image_width` the
// full-resolution width it stands for (sets the map's scale). An empty image gives an empty map.
SignificanceMap independent_saliency(const tiles::Raster& image, double image_width);

}  // namespace zoomwarp::warp
