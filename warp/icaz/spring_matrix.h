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

}  // namespace zoomwarp::warp
