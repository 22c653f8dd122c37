// Graph-Based Visual Saliency [Harel06], as [Kumar (004) §III-B] uses it, with the defaults of
// Harel et al.'s reference code (the paper gives none):
//
//   1. feature maps: Gaussian-pyramid levels 2, 3 and 4 of the image (level 1 is the image), each
//      giving intensity (r+g+b)/3, two colour opponencies (r−g)/max(r,g,b) and
//      (b−min(r,g))/max(r,g,b), and Gabor energy at 0°, 45°, 90°, 135° — 21 maps, each resized to
//      a grid of largest side 32;
//   2. activation: a Markov chain on the complete graph over a map's locations, weight i→j =
//      |M_i − M_j|·exp(−d²/2σ²), σ = 0.15·mean side; its stationary distribution is the map's
//      activation (mass gathers where a location differs from its surroundings);
//   3. normalisation: a second chain, weight i→j = A_j·exp(−d²/2σ²), σ = 0.06·mean side, whose
//      stationary distribution concentrates activation into few places;
//   4. channel = mean of its maps, master = sum of the three channels, Gaussian blur σ = 0.02·the
//      grid's larger side, bilinear up to the size asked for, rescaled to [0, 1].
//
// The difference |M_i − M_j| is the code's choice (the NIPS paper prints |log(M_i/M_j)|).
// Borders have fewer near neighbours, so the chain already favours the centre.
//
// Thread safety: pure functions.
#pragma once

#include <vector>

#include "tiles/raster.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct GbvsOptions {
  int map_max_side = 32;               // feature grid's larger side
  double sigma_activation = 0.15;      // × mean grid side
  double sigma_normalisation = 0.06;   // × mean grid side
  double blur = 0.02;                  // × larger grid side
  double tolerance = 1e-4;             // power iteration: largest change of the distribution
  int max_iterations = 1000;
};

// GBVS of `image` (RGB, RGBA or grey, any size ≥ 1×1) at `out_width` × `out_height` map pixels,
// values in [0, 1] (a featureless image gets the graph's own centre preference; an image of one
// map pixel, 0); `scale` is set for an image `image_width` wide.
// Faces are not painted in here (paint_faces). Throws std::invalid_argument for an empty image
// or a non-positive size.
SignificanceMap compute_gbvs(const tiles::Raster& image, int image_width, int out_width, int out_height,
                             const GbvsOptions& options = {});

// The `gbvs` saliency kind: GBVS of `image` (the analysis image) at its own size, as
// compute_significance makes the default map, with the faces it finds painted in (paint_faces).
SignificanceMap gbvs_significance(const tiles::Raster& image, int image_width, const SignificanceOptions& options = {});

// A Markov chain on n states given by non-negative weights w (row-major n × n, w[i·n + j] the
// weight from i to j), each row normalised to sum 1 (a row of zeros stays in place). Returns its
// stationary distribution π (π = πP, Σπ = 1) by power iteration from `start` (n non-negative
// values, scaled to sum 1; empty: the weights' row sums) until one step of P changes no entry
// by `tolerance` or more, at most `max_iterations` steps. Exposed for tests.
std::vector<double> stationary_distribution(std::vector<double> weights, int n, double tolerance = 1e-4,
                                            int max_iterations = 1000, const std::vector<double>& start = {});

}  // namespace zoomwarp::warp
