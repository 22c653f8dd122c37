// method=polyfem's element: the quadratic serendipity basis on a convex polygon [PolyFEM §3.1
// eq. 1], after [Rand–Gillette–Bajaj], built on mean value coordinates [Floater03]. Plain data in,
// plain data out; no mesh here.
//
// Polygon v_0 … v_{n−1} (n ≥ 3), strictly convex, in order (either orientation); indices mod n.
//
//   MVC      d_i = v_i − p, r_i = |d_i|, α_i the angle at p between d_i and d_{i+1},
//            tan(α_i/2) = (r_i·r_{i+1} − d_i·d_{i+1}) / cross(d_i, d_{i+1}),
//            w_i = (tan(α_{i−1}/2) + tan(α_i/2)) / r_i,  λ_i = w_i / Σ_k w_k;
//            Σ λ_i = 1 and Σ λ_i·v_i = p (linear precision). In a clockwise polygon every cross
//            product, hence every w_i, changes sign; λ does not.
//   diagonal (i, j), j ∉ {i − 1, i, i + 1}: L = |v_j − v_i|, û = (v_j − v_i)/L, v_ij the midpoint,
//            I_i = line(v_i, v_j) ∩ line(v_{i−1}, v_{i+1}), I_j = line(v_i, v_j) ∩ line(v_{j−1}, v_{j+1}),
//            lengths SIGNED along û ([PolyFEM eq. 1] prints unsigned ones, which break constant
//            reproduction once I_i passes v_ij, e.g. on a kite):
//              s      = L / (L − (I_j − I_i)·û)
//              c^{ii} = −s·(1 + 2·(v_ij − I_i)·û / L),   c^{jj} = −s·(1 + 2·(I_j − v_ij)·û / L)
//              c^{i,i−1} = s·|I_i − v_{i+1}| / |v_{i−1} − v_{i+1}|,
//              c^{i,i+1} = s·|I_i − v_{i−1}| / |v_{i−1} − v_{i+1}|,
//              c^{j,j−1}, c^{j,j+1} likewise at j
//            so that c^{ii} + c^{jj} + 2·(c^{i,i−1} + c^{i,i+1} + c^{j,j−1} + c^{j,j+1}) = 2: with
//            Σ_i μ_ii + 2·Σ_edges μ + 2·Σ_diagonals μ = (Σλ)² = 1 this is Σ ψ = 1. In a convex
//            polygon 0 < (I_i − v_i)·û and (I_j − v_i)·û < L, so s > 0, but s → ∞ as I_i → v_i
//            and I_j → v_j, i.e. as the angles at both ends of a diagonal approach π: meshes
//            must keep cell angles away from π.
//   basis    μ_ab = λ_a·λ_b;
//            ξ_ii     = μ_ii + Σ_j c^{ii}_{ij}·μ_ij,
//            ξ_{i,i+1} = μ_{i,i+1} + Σ_j (c^{i,i+1}_{ij}·μ_ij + c^{i+1,i}_{i+1,j}·μ_{i+1,j})
//            (sums over the diagonals at i, resp. i + 1; no factor 2, unlike [PolyFEM eq. 1]);
//            ψ_i = ξ_ii − ξ_{i,i+1} − ξ_{i−1,i} at vertex node v_i (i < n),
//            ψ_{n+i} = 4·ξ_{i,i+1} at edge-midpoint node (v_i + v_{i+1})/2.
//            A triangle has no diagonal: ψ_i = λ_i(2λ_i − 1), ψ_{3+i} = 4λ_iλ_{i+1}, P2 Lagrange.
//            The basis reproduces 1, x, y, x², xy, y²; on an edge (the limit from inside) it is the
//            1-D P2 basis of the edge's three nodes, so neighbouring cells' sums are continuous.
//
// Evaluate only strictly inside the polygon. On an edge a tangent's denominator is 0 and at a
// vertex r_i = 0: the results are NaN or ∞ there. Approaching either, the values tend to their
// limits (δ_km at node m, the edge's 1-D P2 basis on an edge): near an edge the huge tangent
// cancels in the ratio w_i/Σw; near a vertex the rounding of d_i = v_i − p costs about ε·|v|/δ at
// distance δ (the tests: 1e-8 of the way from a node to the centroid, within 3e-7 of δ_km, most
// of it the basis's slope over that distance). Gradients are forward-mode dual numbers through
// the same code (the tests: central differences agree to ~1e-9).
//
// Thread safety: pure functions of their arguments.
#pragma once

#include <vector>

#include "warp/core/mesh.h"

namespace zoomwarp::warp {

// λ_i(p) and ∇λ_i(p) (gradient as (∂/∂x, ∂/∂y)), i < n, for p strictly inside `polygon`.
void mean_value_coordinates(const std::vector<Point>& polygon, const Point& p, std::vector<double>& lambda,
                            std::vector<Point>& gradient);

// The coefficients of one diagonal (i, j), i < j, as named above.
struct SerendipityDiagonal {
  int i = 0, j = 0;
  double c_ii = 0, c_jj = 0;
  double c_i_prev = 0, c_i_next = 0;  // c^{i,i−1}, c^{i,i+1}
  double c_j_prev = 0, c_j_next = 0;  // c^{j,j−1}, c^{j,j+1}
};

// The n(n − 3)/2 diagonals' coefficients of `polygon` — once per cell, for any number of points.
// Throws std::invalid_argument unless n ≥ 3 and the polygon is strictly convex.
std::vector<SerendipityDiagonal> serendipity_coefficients(const std::vector<Point>& polygon);

// ψ_k(p) and ∇ψ_k(p), k < 2n: vertex nodes v_0 … v_{n−1}, then the midpoints of edges
// (v_0, v_1) … (v_{n−1}, v_0); `diagonals` from serendipity_coefficients(polygon) (or any other
// coefficients: tests feed the printed, unsigned ones). p strictly inside.
void serendipity_basis(const std::vector<Point>& polygon, const std::vector<SerendipityDiagonal>& diagonals,
                       const Point& p, std::vector<double>& psi, std::vector<Point>& gradient);

// ψ_k(p) alone: the same values as serendipity_basis's, bit for bit, at about a third of its cost
// (what sampling the elements needs: polyfem_export.h).
void serendipity_values(const std::vector<Point>& polygon, const std::vector<SerendipityDiagonal>& diagonals,
                        const Point& p, std::vector<double>& psi);

}  // namespace zoomwarp::warp
