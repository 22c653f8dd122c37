// method=polyfem's line term (ours, issue 30: [PolyFEM]'s energy has none, and straight edges
// bent by up to 6 screen px under a phone's squeeze). It keeps E_T's two properties that the
// method is built on — quadratic and separate per axis, zero at the identity — so the two solves,
// the axpy per target, the fold-free range and the fallback stay as they are, with K replaced by
// K + L_x on the x axis and K + L_y on the y axis:
//
//   samples  each line (analysis px) sampled at n + 1 equally spaced points p_0 … p_n, n =
//            max(2, ⌈length / spacing⌉); each written through the basis of the cell holding it,
//            f(p) = Σ_k B_k(p)·c_k (polyfem_point_weights: the serendipity basis inside a cell,
//            the edge's 1-D P2 on its border), so the term is in the unknowns;
//   residual the second difference r_k(f_a) = f_a(p_{k−1}) − 2·f_a(p_k) + f_a(p_{k+1}) per axis a:
//            zero along the line exactly when f_a is affine in the line's parameter, which for
//            both axes is a straight image (the form patch uses, [Lin13]'s energy plus ours,
//            written locally: a row touches at most three cells' nodes, so L_a's pattern is K's
//            plus the neighbouring cells a line crosses between); at the identity every r_k is
//            0, since the element reproduces linear functions;
//   weights  E_L = λ·Σ_lines (n³/64)·Σ_k (d_y²·r_k(f_x)² + d_x²·r_k(f_y)²), (d_x, d_y) the line's unit
//            direction. n³/64: a line of any length bent by b px into a circular arc costs λ·b² (its
//            second differences are 8b/n²); d_y², d_x²: a horizontal line is straight when f_y is
//            affine along it, whatever f_x does there — the axis along the line stays free to
//            stretch unevenly, as ICAZ's and mp's normal constraints leave it, and only oblique
//            lines are held to an even stretch in proportion to their slope;
//   no lines L_x = L_y = 0, and K, g_x, g_y are bit for bit those of the term-free energy.
//
// Thread safety: pure functions.
#pragma once

#include <array>
#include <vector>

#include "warp/core/mesh.h"
#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_system.h"

namespace zoomwarp::warp {

struct PolyfemLineTerm {
  SymmetricMatrix x, y;  // L_x, L_y over the nodes (upper triangles); empty without lines
};

// `lines` in analysis px, inside the mesh's rectangle (method_lines.h clips them); lines shorter
// than a pixel have no direction to keep and are left out.
PolyfemLineTerm polyfem_line_term(const PolygonMesh& mesh, const PolyfemNodes& nodes, const std::vector<Segment>& lines,
                                  const PolyfemOptions& options = {});

}  // namespace zoomwarp::warp
