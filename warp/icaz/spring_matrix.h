// The quadratic form Σ_s w_s (u_i − u_j)² of weighted "springs" between vertices — the matrix of
// the shape term's global step (a weighted graph Laplacian, [ICAZ §4.2]) and of orientation-form
// line terms — restricted to the unknowns, assembled directly in compressed column form. A local
// fine solve has ~500 unknowns and is assembled on every view, where going through triplets
// (sorting ~12 per triangle into a row-major temporary, then transposing) cost about three times
// as much. Included only by shape_warp.cc: Eigen/SparseCore stays out of the widely included
// headers. Plain functions; thread-safe.
#pragma once

#include <Eigen/SparseCore>
#include <vector>

namespace zoomwarp::warp {

// w (u_i − u_j)²; i == j adds nothing.
struct Spring {
  int i, j;
  double w;
};

// A matrix entry between an unknown (its row) and a fixed vertex, whose known value moves to the
// right-hand side: b[row] −= value · u_vertex.
struct Coupling {
  int row, vertex;
  double value;
};

// The lower triangle (diagonal included, rows sorted within each column, no duplicates) of the
// form over the unknowns: vertex v is unknown number index[v], or fixed when index[v] < 0; `n`
// unknowns. Entries between an unknown and a fixed vertex are appended to `coupling` if given
// (one per spring end, not merged).
Eigen::SparseMatrix<double> spring_matrix(const std::vector<Spring>& springs, const std::vector<int>& index, int n,
                                          std::vector<Coupling>* coupling = nullptr);

// The same form with fewer unknowns, renumbered, from one spring_matrix made (`lower`, its
// `coupling`): unknown u stays as number keep[u] (`n` of them) or, when keep[u] < 0, becomes
// fixed vertex vertex_of[u]. Its entries with kept unknowns move to `kept_coupling`, as do the
// entries of `coupling` whose row is kept. Cheaper than assembling the springs again: each axis
// of a warp fixes a subset of one set of unknowns, in an order known only once that set is
// ordered.
Eigen::SparseMatrix<double> restricted_form(const Eigen::SparseMatrix<double>& lower, const std::vector<Coupling>& coupling,
                                            const std::vector<int>& keep, int n, const std::vector<int>& vertex_of,
                                            std::vector<Coupling>* kept_coupling);

}  // namespace zoomwarp::warp
