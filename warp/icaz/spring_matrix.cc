#include "warp/icaz/spring_matrix.h"

#include <algorithm>

namespace zoomwarp::warp {

namespace {

// A lower-triangular matrix being filled in compressed columns: column c holds
// rows[start[c] .. end[c]) with `values`, its diagonal first, then distinct rows in any order.
struct Columns {
  std::vector<int> start, end, rows;
  std::vector<double> values;
};

// Room for n columns, column c for its diagonal (placed, value 0) and off_diagonal[c + 1] more
// entries (off_diagonal has n + 1 counts, the first unused).
Columns columns_with_diagonal(int n, std::vector<int> off_diagonal) {
  Columns m;
  m.start = std::move(off_diagonal);
  for (int c = 0; c < n; ++c) m.start[c + 1] += m.start[c] + 1;
  m.rows.resize(std::size_t(m.start[n]));
  m.values.assign(m.rows.size(), 0.0);
  m.end.assign(m.start.begin(), m.start.end() - 1);
  for (int c = 0; c < n; ++c) m.rows[m.end[c]++] = c;
  return m;
}

// The Eigen matrix of m: each column sorted by row (insertion sort: a handful of entries) and the
// columns packed.
Eigen::SparseMatrix<double> compressed(int n, Columns& m) {
  Eigen::SparseMatrix<double> out(n, n);
  auto& [start, end, rows, values] = m;
  int packed = 0;
  for (int c = 0; c < n; ++c) {
    const int first = start[c], last = end[c];
    for (int p = first + 2; p < last; ++p) {
      const int r = rows[p];
      const double v = values[p];
      int q = p;
      for (; q > first + 1 && rows[q - 1] > r; --q) rows[q] = rows[q - 1], values[q] = values[q - 1];
      rows[q] = r, values[q] = v;
    }
    out.outerIndexPtr()[c] = packed;
    for (int p = first; p < last; ++p) rows[packed] = rows[p], values[packed++] = values[p];
  }
  out.outerIndexPtr()[n] = packed;
  out.resizeNonZeros(packed);
  std::copy_n(rows.begin(), packed, out.innerIndexPtr());
  std::copy_n(values.begin(), packed, out.valuePtr());
  return out;
}

}  // namespace

Eigen::SparseMatrix<double> spring_matrix(const std::vector<Spring>& springs, const std::vector<int>& index, int n,
                                          std::vector<Coupling>* coupling) {
  // Column c has room for its diagonal and one entry per spring between c and a higher unknown.
  std::vector<int> off_diagonal(std::size_t(n) + 1, 0);
  for (const Spring& s : springs) {
    const int a = index[s.i], b = index[s.j];
    if (a >= 0 && b >= 0 && a != b) ++off_diagonal[std::min(a, b) + 1];
  }
  Columns m = columns_with_diagonal(n, std::move(off_diagonal));
  auto& [start, end, rows, values] = m;
  for (const Spring& s : springs) {
    const int a = index[s.i], b = index[s.j];
    if (s.i == s.j || a == b) continue;
    if (a >= 0) values[start[a]] += s.w;
    if (b >= 0) values[start[b]] += s.w;
    if (a >= 0 && b >= 0) {
      // A repeat (an interior edge is a spring of both its triangles) adds to its entry: a column
      // holds a few entries, so a linear search is cheaper than sorting repeats out later.
      const int c = std::min(a, b), r = std::max(a, b);
      int p = start[c] + 1;
      while (p < end[c] && rows[p] != r) ++p;
      if (p == end[c]) rows[end[c]++] = r;
      values[p] -= s.w;
    } else if (coupling) {
      if (a >= 0) coupling->push_back({a, s.j, -s.w});
      if (b >= 0) coupling->push_back({b, s.i, -s.w});
    }
  }
  return compressed(n, m);
}

Eigen::SparseMatrix<double> restricted_form(const Eigen::SparseMatrix<double>& lower, const std::vector<Coupling>& coupling,
                                            const std::vector<int>& keep, int n, const std::vector<int>& vertex_of,
                                            std::vector<Coupling>* kept_coupling) {
  // Column j has its diagonal first, then the entries of lower between j and a higher kept unknown.
  std::vector<int> off_diagonal(std::size_t(n) + 1, 0);
  for (int c = 0; c < lower.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator e(lower, c); e; ++e) {
      const int a = keep[e.row()], b = keep[c];
      if (a >= 0 && b >= 0 && a != b) ++off_diagonal[std::min(a, b) + 1];
    }
  Columns m = columns_with_diagonal(n, std::move(off_diagonal));
  auto& [start, end, rows, values] = m;
  for (int c = 0; c < lower.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator e(lower, c); e; ++e) {
      const int a = keep[e.row()], b = keep[c];
      if (a >= 0 && a == b) {
        values[start[a]] = e.value();
      } else if (a >= 0 && b >= 0) {
        const int column = std::min(a, b);
        rows[end[column]] = std::max(a, b), values[end[column]++] = e.value();
      } else if (a >= 0) {
        kept_coupling->push_back({a, vertex_of[c], e.value()});
      } else if (b >= 0) {
        kept_coupling->push_back({b, vertex_of[e.row()], e.value()});
      }
    }
  for (const Coupling& e : coupling)
    if (keep[e.row] >= 0) kept_coupling->push_back({keep[e.row], e.vertex, e.value});
  return compressed(n, m);
}

}  // namespace zoomwarp::warp
