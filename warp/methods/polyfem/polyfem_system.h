// method=polyfem's global system [PolyFEM §3.2 eq. 3, §4.4 eqs 11–12] on a PolygonMesh
// (meshing/polygon_mesh.h), with the serendipity element (serendipity.h):
//
//   nodes    the mesh's vertices, then one node per edge at its midpoint; B_k is the sum of the
//            cells' local ψ at node k [eq. 3], continuous across cells (an edge's restriction is
//            the 1-D P2 basis of its three nodes from either side);
//   energy   E_T(f) = ∫ s·|J(f) − I|²_F [eq. 11], f = Σ_k B_k·c_k: quadratic in c and separate
//            per axis, E_T = Σ_a ∫ s·|∇f_a − e_a|²; s = 0.1 + 0.9·saliency (ours: a cell of
//            zero saliency would make K singular); plus E_L, the line term (ours,
//            polyfem_lines.h), c_xᵀL_x·c_x + c_yᵀL_y·c_y, also separate and zero at the identity —
//            so each axis solves with its own matrix, K + L_x or K + L_y, and all below holds;
//   boundary [eq. 12] x fixed on the left/right nodes (0, W'), y on the top/bottom ones (0, H');
//            the other coordinate slides;
//   solve    by linear precision the identity is stationary at W' = W, H' = H, so
//            c_x(W') = v_x + (W' − W)·g_x with K_ff·g_f = −K_fb·g_b, g_b = 0 on the left, 1 on the
//            right (and g_y likewise): two factorizations (different free sets), two solves, and
//            every target size is an axpy;
//   K        K_kl = ∫ s·∇B_k·∇B_l by quadrature: each cell fanned from its vertex centroid, the fan
//            triangles split in four until ≤ max_triangle_area px², Dunavant's 6-point rule of
//            degree 4 on each (never at a polygon vertex); the gradients shifted by one constant
//            per basis function and cell so that their quadrature sum is ∮ B·n exactly (ours,
//            after [Talischi]'s polynomially consistent quadrature: the basis is rational,
//            and without it the patch test fails by the quadrature error, 2e-6).
//
// Thread safety: pure functions.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/serendipity.h"

namespace zoomwarp::warp {

// A scalar map covering the rectangle width × height (row-major, map_w × map_h samples at pixel
// centres), read bilinearly (clamped at the border).
struct ScalarMap {
  int map_w = 0, map_h = 0;
  double width = 0, height = 0;
  std::vector<float> values;
  double at(const Point& p) const;
};

// One cell's element: its polygon, its serendipity coefficients (serendipity.h) and the vertex
// centroid its fan starts from (the quadrature here, the export's samples).
struct PolyfemElement {
  std::vector<Point> polygon;
  std::vector<SerendipityDiagonal> diagonals;
  Point centroid{0, 0};
  PolyfemElement(const PolygonMesh& mesh, int cell);
};

struct PolyfemNodes {
  std::vector<Point> positions;             // vertices first, then edge midpoints
  std::vector<std::vector<int>> cell_nodes;  // per cell: its n vertex nodes, then its n edge nodes (v_i, v_i+1)
  int vertex_count = 0;
};
PolyfemNodes polyfem_nodes(const PolygonMesh& mesh);

struct PolyfemOptions {
  double saliency_floor = 0.1;     // s = floor + (1 − floor)·saliency (ours)
  double max_triangle_area = 16;   // quadrature triangles, px² (METHODS §3 step 6)
  // The line term (ours, polyfem_lines.h): λ, what a line bent by one analysis px into an arc
  // costs in E_T's units (px²), and the spacing of a line's samples, analysis px. λ = 100: on the
  // corpus at 1 MP, phone screens both ways up, the worst line bends 0.7 screen px (λ = 10:
  // 1.6 px, λ = 1: 4.3 px, λ = 1000: 0.5 px, the export's chord error by then).
  double line_weight = 100;
  double line_spacing = 4;
};

// A symmetric sparse matrix by its upper triangle (row ≤ col), plain data.
struct SymmetricMatrix {
  int size = 0;
  std::vector<int> row, col;
  std::vector<double> value;
};

// g_x, g_y per node: c(W', H') = v + ((W' − W)·g_x, (H' − H)·g_y). K and L_x, L_y too, for the
// fallback's energy: with c = v + d, E_T + E_L = d_xᵀ(K + L_x)·d_x + d_yᵀ(K + L_y)·d_y (the
// identity is stationary, so no linear term is left on the free nodes).
struct PolyfemSolution {
  PolyfemNodes nodes;
  std::vector<double> g_x, g_y;
  SymmetricMatrix stiffness;
  SymmetricMatrix line_x, line_y;  // L_x, L_y; empty without lines
};
// `lines` (analysis px, inside the rectangle) are kept straight by E_L; none: E_T alone.
PolyfemSolution solve_polyfem(const PolygonMesh& mesh, const ScalarMap& saliency, const PolyfemOptions& options = {},
                              const std::vector<Segment>& lines = {});

// (g_x, g_y) per node as one field, what chord deviations of G are measured on (polyfem_export.h).
std::vector<Point> polyfem_g_field(const PolyfemSolution& solution);

// The node positions for a target W' × H': the axpy above.
std::vector<Point> polyfem_positions(const PolyfemSolution& solution, double width, double height, double target_w,
                                     double target_h);

// The targets of the image's area, W·s × H/s (every aspect a view asks for), on which the axpy
// folds nowhere: det J > 0 at every quadrature point for low < s < high (METHODS §3, "Per
// request"). With u = s − 1, ΔW = W·u, ΔH = −H·u/s and a = ∂xG_x, b = ∂yG_x, c = ∂xG_y, d = ∂yG_y,
//
//   s·det J = (1 + ΔW·a)·s·(1 + ΔH·d) − s·ΔW·ΔH·b·c = 1 + (1 + W·a − H·d)·u + (W·a·(1 − H·d) + W·H·b·c)·u²
//
// a quadratic in u with value 1 at u = 0; each point contributes its roots nearest 0, so the
// range is exact for the quadrature points, computed once and stored with the model. low ≥ 0;
// high ≤ kUnboundedAspect where no point bounds it.
struct AspectRange {
  static constexpr double kUnboundedAspect = 1e6;
  double low = 0, high = kUnboundedAspect;
  bool contains(double s) const { return s > low && s < high; }
};
AspectRange polyfem_fold_free_range(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                    const PolyfemOptions& options = {});

// For tests: the same energy solved directly for one target (both axes, their boundary values
// W', H'), by another factorization — what the axpy must reproduce.
std::vector<Point> solve_polyfem_direct(const PolygonMesh& mesh, const ScalarMap& saliency, double target_w,
                                        double target_h, const PolyfemOptions& options = {},
                                        const std::vector<Segment>& lines = {});

}  // namespace zoomwarp::warp
