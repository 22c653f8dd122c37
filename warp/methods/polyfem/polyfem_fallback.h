// method=polyfem where the axpy folds [PolyFEM §4.5]: E_T (with our line term) minimised by L-BFGS from the uniform
// stretch, with per-cell rollback. After every step the cells whose sampled triangles (the
// `check` samplings, usually the export's level 2) turned over get all their nodes reset to the
// previous iterate; cells sharing a reset node are checked again, until none is left. The start
// is affine, so fold-free, and every accepted iterate stays so; the energy never increases
// (lbfgs_rollback.h).
//
//   variables  d = c − v, the node displacements: d_x free except on the left/right border
//              (0, ΔW there), d_y free except on the top/bottom one (0, ΔH) [eq. 12]; each
//              scaled by σ = √(K_kk / (K + L_a)_kk) (ours, Jacobi's scaling: the line term is
//              ~10⁵ times stiffer than E_T along a line, and unscaled the search found no first
//              step); σ = 1 without lines;
//   energy     E_T + E_L = d_xᵀ(K + L_x)·d_x + d_yᵀ(K + L_y)·d_y (polyfem_system.h, polyfem_lines.h),
//              gradient 2·((K + L_a)·d_a) on the free parts.
//
// Why the exported triangles and not det J at the quadrature points, as the axpy's check
// (polyfem_system.h's AspectRange): for arbitrary d that needs every basis gradient at ~250k
// points (tens of MB per version); the samples' weights are there already, and what a client
// sees turning over is exactly an exported triangle.
//
// Thread safety: a pure function.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/stop_token.h"
#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_export.h"
#include "warp/methods/polyfem/polyfem_system.h"

namespace zoomwarp::warp {

struct PolyfemFallback {
  std::vector<Point> displacement;  // per node, analysis px
  double start_energy = 0;          // E_T + E_L of the uniform stretch
  double energy = 0;                // E_T + E_L of the result
  int iterations = 0, rollbacks = 0;  // L-BFGS steps; cells reset over all of them
  bool converged = false;           // a tolerance met (not the iteration limit)
};

// The fold-free deformation of `mesh` (analysis px) onto (W + ΔW) × (H + ΔH), W + ΔW > 0 and
// H + ΔH > 0; `check` holds one sampling per cell.
PolyfemFallback polyfem_fallback(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                 const std::vector<CellSampling>& check, double delta_w, double delta_h,
                                 const StopToken* stop = nullptr);

// True if a triangle of `sampling` turns over (signed area ≤ 0) under `displacement`.
bool polyfem_cell_folds(const CellSampling& sampling, const std::vector<Point>& displacement);

}  // namespace zoomwarp::warp
