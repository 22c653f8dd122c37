#include "warp/methods/polyfem/polyfem_export.h"

#include <algorithm>
#include <array>
#include <map>
#include <stdexcept>

#include "warp/methods/polyfem/serendipity.h"

namespace zoomwarp::warp {

namespace {

// A sample's identity, so that cells sharing an edge (and fan triangles sharing a spoke) share
// the sample: {kind, …} with kinds 0 vertex (id), 1 cell edge (lower id, higher id, lattice
// index from the lower), 2 centroid (cell), 3 spoke (cell, local vertex, lattice index), 4 inside
// (cell, fan triangle, r, s).
using Key = std::array<long long, 5>;

}  // namespace

PolyfemSampling sample_polyfem_cells(const PolygonMesh& mesh, const PolyfemNodes& nodes, int level) {
  if (level < 0 || level > 8) throw std::invalid_argument("polyfem export: subdivision level out of 0…8");
  const int n_lattice = 1 << level;
  PolyfemSampling out;
  std::map<Key, int> index;
  const auto add = [&](const Key& key, const PolyfemSample& sample) {
    auto [it, inserted] = index.emplace(key, int(out.samples.size()));
    if (inserted) {
      out.samples.push_back(sample);
      out.mesh.vertices.push_back(sample.source);
    }
    return it->second;
  };
  for (std::size_t c = 0; c < mesh.cells.size(); ++c) {
    const std::vector<int>& cell = mesh.cells[c];
    const std::size_t n = cell.size();
    Point centroid{0, 0};
    for (int v : cell) centroid = {centroid.x + mesh.vertices[v].x / n, centroid.y + mesh.vertices[v].y / n};
    for (std::size_t i = 0; i < n; ++i) {
      const int vi = cell[i], vj = cell[(i + 1) % n];
      const Point &pi = mesh.vertices[vi], &pj = mesh.vertices[vj];
      // The lattice point r steps toward v_i and s toward v_j from the centroid.
      const auto point = [&](int r, int s) -> int {
        if (r + s == n_lattice) {
          if (r == n_lattice) return add({0, vi, 0, 0, 0}, {PolyfemSample::kAtVertex, pi, -1, vi});
          if (s == n_lattice) return add({0, vj, 0, 0, 0}, {PolyfemSample::kAtVertex, pj, -1, vj});
          // On the cell edge: computed from its lower-id end, so the neighbour gets the same point.
          const int lo = std::min(vi, vj), hi = std::max(vi, vj);
          const int k = vi == lo ? s : r;  // lattice steps from the lower end
          const double t = double(k) / n_lattice;
          const Point &a = mesh.vertices[lo], &b = mesh.vertices[hi];
          PolyfemSample sample{PolyfemSample::kOnEdge, {a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}, -1, lo, hi,
                               nodes.cell_nodes[c][n + i], t};
          return add({1, lo, hi, k, 0}, sample);
        }
        if (r == 0 && s == 0) return add({2, long(c), 0, 0, 0}, {PolyfemSample::kInside, centroid, int(c)});
        if (s == 0 || r == 0) {  // on a spoke, shared by the two fan triangles beside it
          const std::size_t local = s == 0 ? i : (i + 1) % n;
          const int k = s == 0 ? r : s;
          const Point& v = mesh.vertices[cell[local]];
          const double t = double(k) / n_lattice;
          return add({3, long(c), long(local), k, 0},
                     {PolyfemSample::kInside, {centroid.x + t * (v.x - centroid.x), centroid.y + t * (v.y - centroid.y)}, int(c)});
        }
        const double u = double(r) / n_lattice, w = double(s) / n_lattice;
        return add({4, long(c), long(i), r, s},
                   {PolyfemSample::kInside,
                    {centroid.x + u * (pi.x - centroid.x) + w * (pj.x - centroid.x),
                     centroid.y + u * (pi.y - centroid.y) + w * (pj.y - centroid.y)},
                    int(c)});
      };
      const auto triangle = [&](int a, int b, int d) {
        Triangle t{a, b, d};
        if (signed_area2(out.mesh.vertices[a], out.mesh.vertices[b], out.mesh.vertices[d]) < 0) std::swap(t[1], t[2]);
        out.mesh.triangles.push_back(t);
      };
      for (int r = 0; r < n_lattice; ++r)
        for (int s = 0; r + s < n_lattice; ++s) {
          triangle(point(r, s), point(r + 1, s), point(r, s + 1));
          if (r + s + 1 < n_lattice) triangle(point(r + 1, s), point(r + 1, s + 1), point(r, s + 1));
        }
    }
  }
  return out;
}

SampledField sample_polyfem_field(const PolygonMesh& mesh, const PolyfemSolution& solution,
                                  const PolyfemSampling& sampling) {
  SampledField f;
  f.g_x.resize(sampling.samples.size());
  f.g_y.resize(sampling.samples.size());
  std::map<int, std::pair<std::vector<Point>, std::vector<SerendipityDiagonal>>> elements;  // per cell, built once
  std::vector<double> psi;
  std::vector<Point> grad;
  for (std::size_t k = 0; k < sampling.samples.size(); ++k) {
    const PolyfemSample& s = sampling.samples[k];
    double gx = 0, gy = 0;
    switch (s.kind) {
      case PolyfemSample::kAtVertex:
        gx = solution.g_x[s.a], gy = solution.g_y[s.a];
        break;
      case PolyfemSample::kOnEdge: {
        // The edge's restriction of the basis: 1-D P2 through its end and midpoint nodes.
        const double na = (1 - s.t) * (1 - 2 * s.t), nb = s.t * (2 * s.t - 1), nm = 4 * s.t * (1 - s.t);
        gx = na * solution.g_x[s.a] + nb * solution.g_x[s.b] + nm * solution.g_x[s.m];
        gy = na * solution.g_y[s.a] + nb * solution.g_y[s.b] + nm * solution.g_y[s.m];
        break;
      }
      case PolyfemSample::kInside: {
        auto it = elements.find(s.cell);
        if (it == elements.end()) {
          std::vector<Point> polygon;
          for (int v : mesh.cells[s.cell]) polygon.push_back(mesh.vertices[v]);
          auto diagonals = serendipity_coefficients(polygon);
          it = elements.emplace(s.cell, std::make_pair(std::move(polygon), std::move(diagonals))).first;
        }
        serendipity_basis(it->second.first, it->second.second, s.source, psi, grad);
        const std::vector<int>& local = solution.nodes.cell_nodes[s.cell];
        for (std::size_t a = 0; a < local.size(); ++a) gx += psi[a] * solution.g_x[local[a]], gy += psi[a] * solution.g_y[local[a]];
        break;
      }
    }
    f.g_x[k] = gx;
    f.g_y[k] = gy;
  }
  return f;
}

std::vector<Point> warp_polyfem_samples(const PolyfemSampling& sampling, const SampledField& field, double delta_w,
                                        double delta_h) {
  std::vector<Point> out(sampling.samples.size());
  for (std::size_t k = 0; k < out.size(); ++k) {
    const Point& p = sampling.samples[k].source;
    out[k] = {p.x + delta_w * field.g_x[k], p.y + delta_h * field.g_y[k]};
  }
  return out;
}

}  // namespace zoomwarp::warp
