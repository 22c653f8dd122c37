// method=patch's energy [Lin13 §III-C, eqs 1–6] on the quad grid, as a sparse quadratic whose
// minimiser is linear in the target size: every residual is linear in the grid's positions V'
// with a constant part linear in (W', H') and nothing else, so
//
//     V'(W', H') = W'·V_W + H'·V_H,
//
// where V_W, V_H are the solves for the targets (1, 0) and (0, 1) [METHODS §2: two solves
// suffice]. Everything in analysis pixels (Wa × Ha):
//
//   grid     nx = round(Wa/20), ny = round(Ha/20) quads [Lin13 §IV: 20-px quads], cells of
//            Wa/nx × Ha/ny so the grid ends on the border; a quad belongs to the patch covering
//            most of its pixels; E(i) = the edges of patch i's quads (a shared edge belongs to
//            both patches); the representative edge C_i is the edge of E(i) whose midpoint is
//            nearest the patch's pixel centroid;
//   D_ST     [eq. 2] α·s_i·Σ_{j∈E(i)} |e'_j − T_ij·C'_i|², T_ij = [[s, r], [−r, s]] with
//            s = (C·e)/|C|², r = (C_y·e_x − C_x·e_y)/|C|² [eq. 1], so e_j = T_ij·C_i in the source;
//   D_LT     [eq. 3, corrected] (1 − α)(1 − s_i)·Σ_{j∈E(i)} |e'_j − L·e_j|², L = diag(W'/W, H'/H)
//            (printed as L·T_ij·C'_i, which scales the deformed edge twice);
//   D_OR     [eq. 5] per quad (a, b its top edge, d, c its bottom): (y'_a − y'_b)² + (y'_d − y'_c)²
//            + (x'_a − x'_d)² + (x'_b − x'_c)² — grid lines stay axis-aligned;
//   lines    (ours: [Lin13] keeps structure lines through its significance only) each curator or
//            detected line sampled where it crosses an edge of the triangulation the client
//            draws (patch_mesh: quad sides and diagonals), p_k at fraction t_k along it; p_k,
//            and the ends a, b, written affinely in their triangle's corners, so the warped line
//            is exactly the polyline through the warped samples; each stays at t_k between the
//            warped ends: λ·|Q(p_k) − (1 − t_k)·Q(a) − t_k·Q(b)|² — linear, and the line stays
//            straight between samples too (held only every 20 px, it kinked between them by up
//            to 4 screen px on a 4:1 panorama shown on a phone);
//   ε        ε·|V' − V'_stretch|², ε = 1e-8 (ours: positive definite, still linear);
//   boundary hard: x' = 0 / W' on the left / right column, y' = 0 / H' on the top / bottom row
//            ([Lin13]'s soft boundary rows, re-solved until nothing moves, tend to this).
//
// Thread safety: pure functions of their arguments.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/methods/patch/patch_segmentation.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct PatchEnergyOptions {
  double alpha = 0.8;               // α [Lin13 §III-C: 0.8 in all experiments]
  double quad_size = 20;            // px [Lin13 §IV]
  double orientation_weight = 1;    // D_OR's weight (1 in [Lin13]; 0 in tests that drop it)
  double similarity_weight = 1;     // D_ST's weight (1 in [Lin13]; 0 in tests that drop it)
  double line_weight = 1000;        // λ (ours)
  double regularisation = 1e-8;     // ε (ours)
};

// The grid and what the energy reads of the patches, in analysis pixels.
struct PatchGrid {
  double width = 0, height = 0;    // Wa × Ha
  int nx = 0, ny = 0;              // quads per row and column; vertices (nx + 1)(ny + 1), row-major
  std::vector<int> quad_patch;     // per quad (row-major), its patch
  std::vector<double> significance;  // s_i per patch, in [0, 1]: mean saliency over the max [ours]
  int vertex(int i, int j) const { return j * (nx + 1) + i; }
  Point position(int i, int j) const { return {width * i / nx, height * j / ny}; }
};

// The grid over `patches` (made from the analysis image) with each patch's significance: its
// mean over its pixels of `saliency` (any resolution: `saliency.scale` map px per image px, the
// analysis image being `analysis_scale` px per image px), divided by the largest patch mean.
PatchGrid make_patch_grid(const Patches& patches, const SignificanceMap& saliency, double analysis_scale,
                          const PatchEnergyOptions& options = {});

// V_W and V_H: the grid's positions for targets (1, 0) and (0, 1), so that W'·V_W + H'·V_H is
// the minimiser for W' × H'. `lines` in analysis pixels.
struct PatchBasis {
  std::vector<Point> per_width, per_height;
};
PatchBasis solve_patch_basis(const PatchGrid& grid, const std::vector<Segment>& lines,
                             const PatchEnergyOptions& options = {});

// The minimiser for one target, solved directly (tests compare the basis against it).
std::vector<Point> solve_patch_direct(const PatchGrid& grid, const std::vector<Segment>& lines, double target_w,
                                      double target_h, const PatchEnergyOptions& options = {});

}  // namespace zoomwarp::warp
