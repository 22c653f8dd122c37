// method=polyfem's saliency-adaptive polygonal mesh [PolyFEM §4.3.2]: a density from the edges of
// the saliency map, a weighted centroidal Voronoi tessellation of the rectangle [eq. 9], then
// gradient descent of [eq. 10]'s E_se over the seeds' Delaunay triangles until the Voronoi
// diagram has no short edge (METHODS.md §3, precompute steps 2–4).
//
// Plain data in and out, so that CGAL stays in this folder's .cc files.
//
// Thread safety: a pure function, safe to call concurrently.
#pragma once

#include <vector>

#include "warp/meshing/polygon_mesh.h"

namespace zoomwarp::warp {

struct CvtMeshOptions {
  int cells = 200;  // N [PolyFEM §4.3.2: 50–200]
  // N is capped at floor(width·height / min_cell_area) (at least 1), so that tiny or thin
  // rectangles get fewer, not degenerate, cells.
  double min_cell_area = 64;
  int lloyd_side = 512;         // Lloyd runs on a copy of the density whose long side is at most this
  int lloyd_iterations = 100;   // or until no seed moves by 0.01 analysis px
  double min_edge_ratio = 0.05;  // no edge shorter than this fraction of the mean edge [§4.3.2]
  int max_optimisation_steps = 200;
  unsigned long long seed = 15;  // the seeds' RNG (std::mt19937_64)
};

// Meshes [0, width] × [0, height] (analysis px, y down) from `saliency`, a row-major
// map_w × map_h map covering that rectangle.
//
// 1. Density: edges are the map pixels whose Sobel magnitude is ≥ 0.1·max; ρ = 1 on them and
//    1/d³ elsewhere, d ≥ 1 the distance in analysis px to the nearest edge pixel
//    (cv::distanceTransform); ρ = 1 everywhere when there is no edge.
// 2. N seeds drawn from ρ (piecewise constant per map pixel) with a fixed RNG seed — by inverse
//    CDF, which draws from the same distribution as rejection sampling in bounded time.
// 3. Weighted Lloyd on the density resized to ≤ lloyd_side px (labels: nearest seed of each pixel
//    centre, found by scan-converting the clipped Voronoi cells; seeds move to their cells'
//    ρ-weighted centroids).
// 4. Gradient descent of E_se = Σ_t R_t(R_t − 2r_t), R = abc/(4A), r = 2A/(a+b+c), over the
//    Delaunay triangles of the seeds and of their mirror images in the four sides (the mirrors
//    make the Voronoi cells of the seeds exactly their cells clipped to the rectangle, so the
//    clipped edges are optimised too), until no mesh edge is shorter than min_edge_ratio of the
//    mean edge (or than half the rectangle's short side, in a rectangle thinner than that).
//
// Output: one cell per seed (possibly fewer than N, see min_cell_area), each the seed's Voronoi
// cell clipped to the rectangle, counter-clockwise in mesh.h's sense. Vertices are shared: Voronoi
// vertices that coincide within 1e-9·max(width, height) are merged (co-circular seeds — the
// mirrors make every pair of border seeds co-circular with their images — give one vertex of
// higher degree, not a zero-length edge); vertices within that distance of a side lie exactly on
// it, corners are exact. The edges are conforming (a Voronoi diagram: every vertex where cells
// meet is a vertex of each of them).
//
// Throws std::invalid_argument for a non-finite or non-positive size, map_w or map_h < 1, a map
// whose size is not map_w·map_h or with a non-finite value, or options.cells < 1;
// std::runtime_error when max_optimisation_steps steps leave a short edge, or when a cell comes
// out degenerate or not strictly convex (rounding; never seen).
PolygonMesh build_cvt_mesh(const std::vector<float>& saliency, int map_w, int map_h, double width, double height,
                           const CvtMeshOptions& options = {});

}  // namespace zoomwarp::warp
