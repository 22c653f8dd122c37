#include "warp/methods/polyfem/polyfem_export.h"

#include <algorithm>
#include <array>
#include <cmath>
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
  serendipity_values(e.polygon, e.diagonals, p, psi);
  node.insert(node.end(), local.begin(), local.end());
  weight.insert(weight.end(), psi.begin(), psi.end());
}

// A sample's identity within the cell, so that fan triangles share their spokes' and edges'
// samples: its index in the sampling by kind — vertex (local index), cell edge (local edge,
// lattice index), centroid, spoke (local vertex, lattice index), inside (fan triangle, r, s) —
// in one flat table (-1: not sampled yet). A cell at level 4 has ~1 000 samples and is looked up
// six times a lattice triangle: a map there cost more than the basis.
class SampleIndex {
 public:
  SampleIndex(std::size_t n, int lattice) : n_(n), side_(std::size_t(lattice) + 1), slot_(size(), -1) {}
  int& vertex(std::size_t v) { return slot_[v]; }
  int& edge(std::size_t i, int k) { return slot_[n_ + i * side_ + std::size_t(k)]; }
  int& centroid() { return slot_[n_ * (1 + side_)]; }
  int& spoke(std::size_t v, int t) { return slot_[n_ * (1 + side_) + 1 + v * side_ + std::size_t(t)]; }
  int& inside(std::size_t i, int r, int s) {
    return slot_[n_ * (1 + 2 * side_) + 1 + (i * side_ + std::size_t(r)) * side_ + std::size_t(s)];
  }

 private:
  std::size_t size() const { return n_ * (1 + 2 * side_ + side_ * side_) + 1; }
  std::size_t n_, side_;
  std::vector<int> slot_;
};

using Chords = std::vector<std::array<int, 3>>;

// sample_polyfem_cell, and with `coarser` also the chords of every level k = 1 … level (each
// level's lattice edges of level k − 1 on this lattice, as sample_polyfem_cell(…, k) lists them)
// into (*coarser)[k − 1]: the finer lattice holds every coarser one's points, at the same
// coordinates to the bit (k / 2^j = 2k / 2^(j+1)), so their weights and chords are the same.
CellSampling sample_cell(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, int level,
                         std::vector<Chords>* coarser) {
  if (level < 0 || level > kMaxPolyfemLevel) throw std::invalid_argument("polyfem export: subdivision level out of range");
  const PolyfemElement e(mesh, cell);
  const std::vector<int>& ids = mesh.cells[cell];
  const std::vector<int>& local = nodes.cell_nodes.at(cell);
  const std::size_t n = ids.size();
  const int lattice = 1 << level;
  CellSampling out;
  out.offset.push_back(0);
  SampleIndex index(n, lattice);
  const auto add = [&](int& slot, const Point& p, auto&& weights) {
    if (slot < 0) {
      slot = int(out.source.size());
      out.source.push_back(p);
      weights();
      out.offset.push_back(int(out.node.size()));
    }
    return slot;
  };
  if (coarser) coarser->assign(std::size_t(level), {});
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t j = (i + 1) % n;
    const Point &pi = e.polygon[i], &pj = e.polygon[j];
    // Lattice point (r, s): r steps toward v_i and s toward v_j from the centroid.
    const auto point = [&](int r, int s) -> int {
      if (r == lattice || s == lattice) {
        const std::size_t v = r == lattice ? i : j;
        return add(index.vertex(v), e.polygon[v], [&] {
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
        return add(index.edge(i, k), Point{a.x + t * (b.x - a.x), a.y + t * (b.y - a.y)}, [&] {
          edge_weights(std::min(ids[i], ids[j]), std::max(ids[i], ids[j]), local[n + i], t, out.node, out.weight);
        });
      }
      if (r == 0 && s == 0)
        return add(index.centroid(), e.centroid, [&] { inside_weights(e, local, e.centroid, out.node, out.weight); });
      Point p;
      int* slot;
      if (r == 0 || s == 0) {  // on a spoke, shared by the two fan triangles beside it
        const std::size_t v = s == 0 ? i : j;
        const double t = double(s == 0 ? r : s) / lattice;
        p = {e.centroid.x + t * (e.polygon[v].x - e.centroid.x), e.centroid.y + t * (e.polygon[v].y - e.centroid.y)};
        slot = &index.spoke(v, s == 0 ? r : s);
      } else {
        const double u = double(r) / lattice, w = double(s) / lattice;
        p = {e.centroid.x + u * (pi.x - e.centroid.x) + w * (pj.x - e.centroid.x),
             e.centroid.y + u * (pi.y - e.centroid.y) + w * (pj.y - e.centroid.y)};
        slot = &index.inside(i, r, s);
      }
      return add(*slot, p, [&] { inside_weights(e, local, p, out.node, out.weight); });
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
    // Level k's chords: the level below's lattice edges (2r, 2s)–(2r + 2, 2s), (2r, 2s)–(2r, 2s + 2)
    // and (2r + 2, 2s)–(2r, 2s + 2) with their midpoints (spokes twice: harmless for a maximum),
    // on level k's lattice, which is this one's every f-th point.
    const auto chords = [&](int k, Chords& list) {
      const int f = 1 << (level - k);
      const auto at = [&](int r, int s) { return point(r * f, s * f); };
      for (int r = 0; 2 * r < (1 << k); ++r)
        for (int s = 0; 2 * (r + s) < (1 << k); ++s) {
          list.push_back({at(2 * r, 2 * s), at(2 * r + 1, 2 * s), at(2 * r + 2, 2 * s)});
          list.push_back({at(2 * r, 2 * s), at(2 * r, 2 * s + 1), at(2 * r, 2 * s + 2)});
          list.push_back({at(2 * r + 2, 2 * s), at(2 * r + 1, 2 * s + 1), at(2 * r, 2 * s + 2)});
        }
    };
    if (level > 0) chords(level, out.chords);
    for (int k = 1; coarser && k <= level; ++k) chords(k, (*coarser)[std::size_t(k - 1)]);
  }
  return out;
}

// Per axis, the largest distance of a chord's displaced midpoint from the mean of its displaced
// ends; `moved` holds every sample's displacement.
Point chord_deviation(const Chords& chords, const std::vector<Point>& moved) {
  Point worst{0, 0};
  for (const auto& [a, m, b] : chords) {
    const Point &da = moved[a], &dm = moved[m], &db = moved[b];
    worst = {std::max(worst.x, std::abs(dm.x - (da.x + db.x) / 2)), std::max(worst.y, std::abs(dm.y - (da.y + db.y) / 2))};
  }
  return worst;
}

// Every sample's displacement Σ w·d.
std::vector<Point> sample_displacements(const CellSampling& sampling, const std::vector<Point>& displacement) {
  std::vector<Point> moved(sampling.source.size());
  for (std::size_t i = 0; i < moved.size(); ++i) {
    Point d{0, 0};
    for (int j = sampling.offset[i]; j < sampling.offset[i + 1]; ++j)
      d = {d.x + sampling.weight[j] * displacement[sampling.node[j]].x, d.y + sampling.weight[j] * displacement[sampling.node[j]].y};
    moved[i] = d;
  }
  return moved;
}

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
  return sample_cell(mesh, nodes, cell, level, nullptr);
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
  return chord_deviation(finer.chords, sample_displacements(finer, displacement));
}

std::vector<Point> polyfem_chord_deviations(const PolygonMesh& mesh, const PolyfemNodes& nodes, int cell, int levels,
                                            const std::vector<Point>& displacement) {
  if (levels < 1) throw std::invalid_argument("polyfem export: at least one chord level");
  std::vector<Chords> chords;
  const CellSampling finest = sample_cell(mesh, nodes, cell, levels, &chords);
  const std::vector<Point> moved = sample_displacements(finest, displacement);
  std::vector<Point> out;
  for (const Chords& level : chords) out.push_back(chord_deviation(level, moved));
  return out;
}

}  // namespace zoomwarp::warp
