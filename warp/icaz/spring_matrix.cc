#include "warp/icaz/spring_matrix.h"

#include <algorithm>

namespace zoomwarp::warp {

namespace {

// The lower-triangular matrix whose column c holds rows[start[c] .. end[c]) (its diagonal first,
// then distinct rows in any order) with `values`: each column sorted by row (insertion sort: a
// handful of entries) and the columns packed.
Eigen::SparseMatrix<double> compressed(int n, const std::vector<int>& start, const std::vector<int>& end,
                                       std::vector<int>& rows, std::vector<double>& values) {
  Eigen::SparseMatrix<double> m(n, n);
  int out = 0;
  for (int c = 0; c < n; ++c) {
    const int first = start[c], last = end[c];
    for (int p = first + 2; p < last; ++p) {
      const int r = rows[p];
      const double v = values[p];
      int q = p;
      for (; q > first + 1 && rows[q - 1] > r; --q) rows[q] = rows[q - 1], values[q] = values[q - 1];
      rows[q] = r, values[q] = v;
    }
    m.outerIndexPtr()[c] = out;
    for (int p = first; p < last; ++p) rows[out] = rows[p], values[out++] = values[p];
  }
  m.outerIndexPtr()[n] = out;
  m.resizeNonZeros(out);
  std::copy_n(rows.begin(), out, m.innerIndexPtr());
  std::copy_n(values.begin(), out, m.valuePtr());
  return m;
}

}  // namespace

Eigen::SparseMatrix<double> spring_matrix(const std::vector<Spring>& springs, const std::vector<int>& index, int n,
                                          std::vector<Coupling>* coupling) {
  // Column c has room for its diagonal (first) and one entry per spring between c and a higher
  // unknown.
  std::vector<int> start(std::size_t(n) + 1, 0);
  for (int c = 0; c < n; ++c) start[c + 1] = 1;
  for (const Spring& s : springs) {
    const int a = index[s.i], b = index[s.j];
    if (a >= 0 && b >= 0 && a != b) ++start[std::min(a, b) + 1];
  }
  for (int c = 0; c < n; ++c) start[c + 1] += start[c];
  std::vector<int> rows(std::size_t(start[n]));
  std::vector<double> values(rows.size(), 0.0);
  std::vector<int> end(start.begin(), start.end() - 1);
  for (int c = 0; c < n; ++c) rows[end[c]++] = c;
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
  return compressed(n, start, end, rows, values);
}

Eigen::SparseMatrix<double> restricted_form(const Eigen::SparseMatrix<double>& lower, const std::vector<Coupling>& coupling,
                                            const std::vector<int>& keep, int n, const std::vector<int>& vertex_of,
                                            std::vector<Coupling>* kept_coupling) {
  // Column j has its diagonal first, then the entries of lower between j and a higher kept unknown.
  std::vector<int> start(std::size_t(n) + 1, 0);
  for (int c = 0; c < n; ++c) start[c + 1] = 1;
  for (int c = 0; c < lower.outerSize(); ++c)
    for (Eigen::SparseMatrix<double>::InnerIterator e(lower, c); e; ++e) {
      const int a = keep[e.row()], b = keep[c];
      if (a >= 0 && b >= 0 && a != b) ++start[std::min(a, b) + 1];
    }
  for (int c = 0; c < n; ++c) start[c + 1] += start[c];
  std::vector<int> rows(std::size_t(start[n]));
  std::vector<double> values(rows.size(), 0.0);
  std::vector<int> end(start.begin(), start.end() - 1);
  for (int c = 0; c < n; ++c) rows[end[c]++] = c;
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
  return compressed(n, start, end, rows, values);
}

}  // namespace zoomwarp::warp
