#include "warp/methods/polyfem/polyfem_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <stdexcept>

#include "warp/methods/polyfem/serendipity.h"

namespace zoomwarp::warp {

namespace {

// The 1-D P2 weights of the point at parameter t along the edge from node lo to node hi (lower
// vertex id first) with midpoint node m: the restriction of every B_k to the edge.
void edge_weights(int lo, int hi, int m, double t, std::vector<int>& node, std::vector<double>& weight) {
  node.insert(node.end(), {lo, hi, m});
  weight.insert(weight.end(), {(1 - t) * (1 - 2 * t), t * (2 * t - 1), 4 * t * (1 - t)});
}

void inside_weights(const PolyfemElement& e, const std::vector<int>& local, const Point& p, std::vector<int>& node,
                    std::vector<double>& weight) {
  static thread_local std::vector<double> psi;
  static thread_local std::vector<Point> gradient;
  serendipity_basis(e.polygon, e.diagonals, p, psi, gradient);
  node.insert(node.end(), local.begin(), local.end());
  weight.insert(weight.end(), psi.begin(), psi.end());
}

// A sample's identity within the cell, so that fan triangles share their spokes' and edges'
// samples: {kind, a, b, c} with kinds 0 vertex (local index), 1 cell edge (local edge, lattice
// index), 2 centroid, 3 spoke (local vertex, lattice index), 4 inside (fan triangle, r, s).
using Key = std::array<int, 4>;

}  // namespace

std::size_t CellSampling::memory_bytes() const {
  return source.capacity() * sizeof(Point) + triangles.capacity() * sizeof(Triangle) +
         (offset.capacity() + node.capacity()) * sizeof(int) + weight.capacity() * sizeof(double) +
         chords.capacity() * sizeof(chords[0]);
}

long polyfem_cell_triangles(const PolygonMesh& mesh, int cell, int level) {
  return long(mesh.cells.at(cell).size()) << (2 * level);
}

CellSampling sample_polyfem_cell(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, int level) {
  if (level < 0 || level > kMaxPolyfemLevel) throw std::invalid_argument("polyfem export: subdivision level out of range");
  const PolyfemElement e(mesh, cell);
  const std::vector<int>& ids = mesh.cells[cell];
  const std::vector<int>& local = nodes.cell_nodes.at(cell);
  const std::size_t n = ids.size();
  const int lattice = 1 << level;
  CellSampling out;
  out.offset.push_back(0);
  std::map<Key, int> index;
  const auto add = [&](const Key& key, const Point& p, auto&& weights) {
    auto [it, inserted] = index.emplace(key, int(out.source.size()));
    if (inserted) {
      out.source.push_back(p);
      weights();
      out.offset.push_back(int(out.node.size()));
    }
    return it->second;
  };
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    const Point &pi = e.polygon[i], &pj = e.polygon[j];
    // Lattice point (r, s): r steps toward v_i and s toward v_j from the centroid.
    const auto point = [&](int r, int s) -> int {
      if (r == lattice || s == lattice) {
        const std::size_t v = r == lattice ? i : j;
        return add({0, int(v), 0, 0}, e.polygon[v], [&] {
          out.node.push_back(ids[v]);
          out.weight.push_back(1);
        });
      }
      if (r + s == lattice) {
        // On the cell edge, parametrised from its lower-id end as the neighbour does it.
        const bool i_low = ids[i] < ids[j];
        const int k = i_low ? s : r;
        const double t = double(k) / lattice;
        const Point &a = i_low ? pi : pj, &b = i_low ? pj : pi;
        return add({1, int(i), k, 0}, Point{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}, [&] {
          edge_weights(std::min(ids[i], ids[j]), std::max(ids[i], ids[j]), local[n + i], t, out.node, out.weight);
        });
      }
      Point p;
      Key key;
      if (r == 0 && s == 0) {
        p = e.centroid, key = {2, 0, 0, 0};
      } else if (r == 0 || s == 0) {  // on a spoke, shared by the two fan triangles beside it
        const std::size_t v = s == 0 ? i : j;
        const double t = double(s == 0 ? r : s) / lattice;
        p = {e.centroid.x + t * (e.polygon[v].x - e.centroid.x), e.centroid.y + t * (e.polygon[v].y - e.centroid.y)};
        key = {3, int(v), s == 0 ? r : s, 0};
      } else {
        const double u = double(r) / lattice, w = double(s) / lattice;
        p = {e.centroid.x + u * (pi.x - e.centroid.x) + w * (pj.x - e.centroid.x),
             e.centroid.y + u * (pi.y - e.centroid.y) + w * (pj.y - e.centroid.y)};
        key = {4, int(i), r, s};
      }
      return add(key, p, [&] { inside_weights(e, local, p, out.node, out.weight); });
    };
    const auto triangle = [&](int a, int b, int c) {
      Triangle t{a, b, c};
      if (signed_area2(out.source[a], out.source[b], out.source[c]) < 0) std::swap(t[1], t[2]);
      out.triangles.push_back(t);
    };
    for (int r = 0; r < lattice; ++r)
      for (int s = 0; r + s < lattice; ++s) {
        triangle(point(r, s), point(r + 1, s), point(r, s + 1));
        if (r + s + 1 < lattice) triangle(point(r + 1, s), point(r + 1, s + 1), point(r, s + 1));
      }
    // The level below's lattice edges: (2r, 2s)–(2r + 2, 2s), (2r, 2s)–(2r, 2s + 2) and
    // (2r + 2, 2s)–(2r, 2s + 2) with their midpoints (spokes twice: harmless for a maximum).
    for (int r = 0; level > 0 && 2 * r < lattice; ++r)
      for (int s = 0; 2 * (r + s) < lattice; ++s) {
        out.chords.push_back({point(2 * r, 2 * s), point(2 * r + 1, 2 * s), point(2 * r + 2, 2 * s)});
        out.chords.push_back({point(2 * r, 2 * s), point(2 * r, 2 * s + 1), point(2 * r, 2 * s + 2)});
        out.chords.push_back({point(2 * r + 2, 2 * s), point(2 * r + 1, 2 * s + 1), point(2 * r, 2 * s + 2)});
      }
  }
  return out;
}

void displace_cell_samples(const CellSampling& sampling, const std::vector<Point>& displacement,
                           std::vector<Point>& out) {
  for (std::size_t i = 0; i < sampling.source.size(); ++i) {
    double dx = 0, dy = 0;
    for (int j = sampling.offset[i]; j < sampling.offset[i + 1]; ++j) {
      const Point& d = displacement[sampling.node[j]];
      dx += sampling.weight[j] * d.x, dy += sampling.weight[j] * d.y;
    }
    out.push_back({sampling.source[i].x + dx, sampling.source[i].y + dy});
  }
}

void polyfem_point_weights(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, const Point& p,
                           std::vector<int>& node, std::vector<double>& weight) {
  const std::vector<int>& ids = mesh.cells.at(cell);
  const std::size_t n = ids.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Point &a = mesh.vertices[ids[i]], &b = mesh.vertices[ids[(i + 1) % n]];
    const double length2 = (b.x - a.x) * (b.x - a.x) + (b.y - a.y) * (b.y - a.y);
    const double t = ((p.x - a.x) * (b.x - a.x) + (p.y - a.y) * (b.y - a.y)) / length2;
    // On the edge up to rounding: the interior formula is undefined there (serendipity.h).
    if (std::abs(signed_area2(a, b, p)) <= 1e-9 * length2 && t >= -1e-9 && t <= 1 + 1e-9) {
      const bool a_low = ids[i] < ids[(i + 1) % n];
      edge_weights(std::min(ids[i], ids[(i + 1) % n]), std::max(ids[i], ids[(i + 1) % n]),
                   nodes.cell_nodes[cell][n + i], std::clamp(a_low ? t : 1 - t, 0.0, 1.0), node, weight);
      return;
    }
  }
  inside_weights(PolyfemElement(mesh, cell), nodes.cell_nodes[cell], p, node, weight);
}

Point polyfem_chord_deviation(const CellSampling& finer, const std::vector<Point>& displacement) {
  const auto moved = [&](int i) {
    Point d{0, 0};
    for (int j = finer.offset[i]; j < finer.offset[i + 1]; ++j)
      d = {d.x + finer.weight[j] * displacement[finer.node[j]].x, d.y + finer.weight[j] * displacement[finer.node[j]].y};
    return d;
  };
  Point worst{0, 0};
  for (const auto& [a, m, b] : finer.chords) {
    const Point da = moved(a), dm = moved(m), db = moved(b);
    worst = {std::max(worst.x, std::abs(dm.x - (da.x + db.x) / 2)), std::max(worst.y, std::abs(dm.y - (da.y + db.y) / 2))};
  }
  return worst;
}

}  // namespace zoomwarp::warp
