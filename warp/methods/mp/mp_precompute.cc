#include "warp/methods/mp/mp_precompute.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <optional>
#include <stdexcept>
#include <unordered_map>
#include <opencv2/imgproc.hpp>

#include "warp/core/triangle_locator.h"
#include "warp/lines/line_detection.h"
#include "warp/meshing/constrained_mesh.h"
#include "warp/methods/model_bytes.h"
#include "warp/saliency/attention.h"

namespace zoomwarp::warp {

namespace {

// The line detector's Canny settings (lines/line_detection.cc): the same edges feed both.
constexpr double kCannyLow = 30, kCannyHigh = 90;

double length(const Segment& s) { return std::hypot(s.b.x - s.a.x, s.b.y - s.a.y); }

// The kept points in cells of side `cell`, for "is anything within r ≤ cell" queries.
class PointGrid {
 public:
  PointGrid(double cell) : cell_(cell) {}
  void add(const Point& p) { cells_[key(cell_of(p.x), cell_of(p.y))].push_back(p); }
  bool any_within(const Point& p, double r) const {
    const long long cx = cell_of(p.x), cy = cell_of(p.y);
    for (long long y = cy - 1; y <= cy + 1; ++y)
      for (long long x = cx - 1; x <= cx + 1; ++x)
        if (auto it = cells_.find(key(x, y)); it != cells_.end())
          for (const Point& q : it->second)
            if ((q.x - p.x) * (q.x - p.x) + (q.y - p.y) * (q.y - p.y) < r * r) return true;
    return false;
  }

 private:
  long long cell_of(double v) const { return (long long)std::floor(v / cell_); }
  static long long key(long long x, long long y) { return x * 1000003LL + y; }
  double cell_;
  std::unordered_map<long long, std::vector<Point>> cells_;
};

cv::Mat grey_of(const tiles::Raster& image) {
  const int type = image.channels == 1 ? CV_8UC1 : image.channels == 2 ? CV_8UC2 : image.channels == 3 ? CV_8UC3 : CV_8UC4;
  const cv::Mat in(image.height, image.width, type, const_cast<std::uint8_t*>(image.pixels.data()));
  cv::Mat grey;
  if (image.channels == 1) grey = in.clone();
  else if (image.channels == 2) cv::extractChannel(in, grey, 0);
  else cv::cvtColor(in, grey, image.channels == 4 ? cv::COLOR_RGBA2GRAY : cv::COLOR_RGB2GRAY);
  return grey;
}

struct FeaturePoints {
  std::vector<Point> points;
  std::vector<std::array<int, 2>> constraints;
  std::vector<Segment> lines;  // the line pieces the points were placed on
  std::vector<int> piece_line;  // per piece, which line (of the curator's, then detected) it is of
  std::vector<std::optional<Segment>> whole;  // per line, clipped to the image (none: outside it)
};

FeaturePoints feature_points(const MethodInput& input, double wa, double ha, double d) {
  FeaturePoints out;
  PointGrid grid(d);
  const auto keep = [&](const Point& p) {
    out.points.push_back(p);
    grid.add(p);
  };

  // The border every ~d, corners included [Guo09 §3.2]; the same step as the auxiliary grid so
  // that both line up.
  const int nx = std::max(1, int(std::lround(wa / d))), ny = std::max(1, int(std::lround(ha / d)));
  for (int i = 0; i < nx; ++i) keep({wa * i / nx, 0});
  for (int j = 0; j < ny; ++j) keep({wa, ha * j / ny});
  for (int i = nx; i > 0; --i) keep({wa * i / nx, ha});
  for (int j = ny; j > 0; --j) keep({0, ha * j / ny});

  // Lines [Guo09 §3.3.3]: the curator's first, then the detected ones (longest first).
  std::vector<Segment> candidates;
  if (input.model.width > 0 && input.model.height > 0) {
    const double sx = wa / input.model.width, sy = ha / input.model.height;
    for (const auto* set : {&input.lines, &input.detected_lines})
      for (const Segment& s : *set) candidates.push_back({{s.a.x * sx, s.a.y * sy}, {s.b.x * sx, s.b.y * sy}});
  }
  const double inset = d / 4;
  for (std::size_t line = 0; line < candidates.size(); ++line) {
    out.whole.push_back(clip_segment(candidates[line], 0, 0, wa, ha));
    const auto c = clip_segment(candidates[line], inset, inset, wa - inset, ha - inset);
    if (!c) continue;
    for (const Segment& piece : clear_pieces(*c, out.lines, d / 2, d)) {
      out.lines.push_back(piece);
      out.piece_line.push_back(int(line));
      const int n = std::max(2, int(std::ceil(length(piece) / (d / 2))));
      for (int k = 0; k <= n; ++k) {
        if (k > 0) out.constraints.push_back({int(out.points.size()) - 1, int(out.points.size())});
        // The end points exactly, so that the chain lies on the piece.
        const Point p = k == n ? piece.b
                               : Point{piece.a.x + (piece.b.x - piece.a.x) * k / n, piece.a.y + (piece.b.y - piece.a.y) * k / n};
        keep(p);
      }
    }
  }

  // Canny pixels, row by row, each kept when ≥ d from every point kept so far [Guo09 §3.2].
  // Images under 5 px a side have no edges worth a point (and the 5×5 blur needs the room).
  if (input.analysis_image.width >= 5 && input.analysis_image.height >= 5) {
    cv::Mat grey = grey_of(input.analysis_image), edges;
    cv::GaussianBlur(grey, grey, cv::Size(5, 5), 0);
    cv::Canny(grey, edges, kCannyLow, kCannyHigh, 3, /*L2gradient=*/true);
    for (int y = 0; y < edges.rows; ++y)
      for (int x = 0; x < edges.cols; ++x)
        if (edges.at<std::uint8_t>(y, x)) {
          const Point p{x + 0.5, y + 0.5};
          if (p.x < wa && p.y < ha && !grid.any_within(p, d)) keep(p);
        }
  }

  // Auxiliary points on the interior nodes of the d-grid, where nothing lies within 0.75d, for a
  // nearly uniform density [Guo09 §3.2].
  for (int j = 1; j < ny; ++j)
    for (int i = 1; i < nx; ++i) {
      const Point p{wa * i / nx, ha * j / ny};
      if (!grid.any_within(p, 0.75 * d)) keep(p);
    }
  return out;
}

// Pixel centres (x + 0.5, y + 0.5) inside triangle (a, b, c), edges included, as
// mean_over_triangle counts them.
template <class F>
void for_pixels_in(const Point& a, const Point& b, const Point& c, int w, int h, F f) {
  const double area2 = signed_area2(a, b, c);
  const int x0 = std::max(0, int(std::floor(std::min({a.x, b.x, c.x}))));
  const int x1 = std::min(w - 1, int(std::ceil(std::max({a.x, b.x, c.x}))));
  const int y0 = std::max(0, int(std::floor(std::min({a.y, b.y, c.y}))));
  const int y1 = std::min(h - 1, int(std::ceil(std::max({a.y, b.y, c.y}))));
  for (int y = y0; y <= y1; ++y)
    for (int x = x0; x <= x1; ++x) {
      const Point q{x + 0.5, y + 0.5};
      const double e0 = signed_area2(a, b, q), e1 = signed_area2(b, c, q), e2 = signed_area2(c, a, q);
      if ((area2 > 0 && e0 >= 0 && e1 >= 0 && e2 >= 0) || (area2 < 0 && e0 <= 0 && e1 <= 0 && e2 <= 0)) f(x, y);
    }
}

// Which triangles are salient enough to be part of an object.
std::vector<bool> object_triangles(const MethodInput& input, const Mesh& mesh, double wa,
                                   const MpPrecomputeOptions& options) {
  std::vector<bool> in(mesh.triangles.size(), false);
  const SignificanceMap& s = input.saliency;
  if (s.values.empty() || s.width <= 0) return in;
  // The map in analysis px: mean_over_triangle scales its points by `scale`.
  SignificanceMap map;
  map.width = s.width;
  map.height = s.height;
  map.scale = s.width / wa;
  if (input.saliency_kind == Saliency::kGbvs) {
    // [Kumar (004) §III-B]: the kept attention regions as a 0/1 map, so that a triangle's mean is
    // the share of its area inside them.
    const AttentionRegions regions = attention_regions(s);
    std::vector<bool> kept(regions.regions.size() + 1, false);
    for (const AttentionRegion& r : regions.kept(options.attention_fraction)) kept[std::size_t(r.label)] = true;
    map.values.resize(regions.labels.size());
    for (std::size_t i = 0; i < regions.labels.size(); ++i) map.values[i] = kept[std::size_t(regions.labels[i])] ? 1.f : 0.f;
  } else {
    map.values = s.values;
  }
  std::vector<double> mean(mesh.triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    mean[f] = mean_over_triangle(map, mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
  }
  // Sμ is on 001's scale, a map whose most salient region is 1; ours (faces and curator edits
  // aside) peaks at 0.5–0.7 over a triangle, which would leave no object on real photographs. So
  // the threshold is Sμ times the largest triangle mean (ours).
  const double top = mean.empty() ? 0 : *std::max_element(mean.begin(), mean.end());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    in[f] = input.saliency_kind == Saliency::kGbvs ? mean[f] >= options.region_cover
                                                   : top > 0 && mean[f] > options.object_saliency * top;
  return in;
}

int root(std::vector<int>& parent, int i) {
  while (parent[i] != i) i = parent[i] = parent[parent[i]];
  return i;
}

void add_objects(MpModel& model, const std::vector<bool>& salient, const MpPrecomputeOptions& options) {
  const Mesh& mesh = model.mesh;
  std::vector<int> parent(mesh.vertices.size());
  std::iota(parent.begin(), parent.end(), 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    if (salient[f]) {
      const auto& t = mesh.triangles[f];
      parent[root(parent, t[1])] = root(parent, t[0]);
      parent[root(parent, t[2])] = root(parent, t[0]);
    }
  // Components in the order of their first triangle, so that the model is deterministic.
  std::unordered_map<int, int> component;
  std::vector<std::vector<int>> triangles;
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f)
    if (salient[f]) {
      const auto [it, added] = component.emplace(root(parent, mesh.triangles[f][0]), int(triangles.size()));
      if (added) triangles.emplace_back();
      triangles[std::size_t(it->second)].push_back(int(f));
    }

  // Each component's vertices, then its region: every triangle whose corners are all its own.
  // That is what moves rigidly under [Guo09 eq. 3] — a notch that a non-salient triangle closes
  // between three object vertices moves with the object — so the area and the masks are taken
  // over it (ours; [Guo09] leaves the notch undecided).
  std::vector<int> label(mesh.vertices.size(), -1);
  std::vector<std::vector<int>> vertices(triangles.size());
  for (std::size_t c = 0; c < triangles.size(); ++c) {
    for (int f : triangles[c])
      for (int v : mesh.triangles[std::size_t(f)]) label[std::size_t(v)] = int(c);
    for (int v = 0; v < int(mesh.vertices.size()); ++v)
      if (label[std::size_t(v)] == int(c)) vertices[c].push_back(v);
  }
  std::vector<std::vector<int>> region(triangles.size());
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    const auto& t = mesh.triangles[f];
    if (label[std::size_t(t[0])] >= 0 && label[std::size_t(t[0])] == label[std::size_t(t[1])] &&
        label[std::size_t(t[0])] == label[std::size_t(t[2])])
      region[std::size_t(label[std::size_t(t[0])])].push_back(int(f));
  }

  const double wa = model.width, ha = model.height;
  const int iw = int(std::lround(wa)), ih = int(std::lround(ha));
  std::vector<std::uint8_t> mask(std::size_t(iw) * std::size_t(ih), 0);
  for (std::size_t c = 0; c < triangles.size(); ++c) {
    MpObject o;
    o.vertices = std::move(vertices[c]);
    for (int f : region[c]) {
      const auto& t = mesh.triangles[std::size_t(f)];
      o.area += 0.5 * signed_area2(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]]);
    }
    if (o.area < options.min_object_fraction * wa * ha) continue;
    // Kept also when it touches two opposite borders: mp_solve then fixes its scale across them
    // (ours, mp_solve.h) — dropping it left the largest salient shapes, a façade spanning the
    // width, to bend with the background.
    for (int v : o.vertices) {
      const Point& p = mesh.vertices[std::size_t(v)];
      o.pole.x += p.x / double(o.vertices.size());
      o.pole.y += p.y / double(o.vertices.size());
    }
    for (int f : region[c]) {
      const auto& t = mesh.triangles[std::size_t(f)];
      for_pixels_in(mesh.vertices[t[0]], mesh.vertices[t[1]], mesh.vertices[t[2]], iw, ih,
                    [&](int x, int y) { mask[std::size_t(y) * iw + x] = 1; });
    }
    model.objects.push_back(std::move(o));
  }
  model.row_object_length.assign(std::size_t(ih), 0);
  model.column_object_length.assign(std::size_t(iw), 0);
  for (int y = 0; y < ih; ++y)
    for (int x = 0; x < iw; ++x)
      if (mask[std::size_t(y) * iw + x]) {
        model.row_object_length[std::size_t(y)] += 1;
        model.column_object_length[std::size_t(x)] += 1;
      }
}

// One line's points (mp_model.h): its ends and samples every ≤ d/4 along `whole`, located in the
// mesh, and the vertices of its chains `pieces` (clear_pieces gives them from the line's start on;
// refinement only splits constrained edges at their midpoints, which stay on the piece), all in
// order along it.
MpLine line_points(const Mesh& mesh, const TriangleLocator& locator, const Segment& whole,
                   const std::vector<Segment>& pieces, double d) {
  const Point e{whole.b.x - whole.a.x, whole.b.y - whole.a.y};
  const double len2 = e.x * e.x + e.y * e.y;
  std::vector<std::pair<double, MpLinePoint>> along;  // (parameter along `whole`, point)
  const int n = std::max(1, int(std::ceil(length(whole) / (d / 4))));
  for (int k = 0; k <= n; ++k) {
    // The ends exactly, so that the line's ends are its segment's.
    const Point p = k == n ? whole.b : Point{whole.a.x + e.x * k / n, whole.a.y + e.y * k / n};
    const MeshPoint where = locator.find(p);
    const Triangle& t = mesh.triangles[std::size_t(where.triangle)];
    along.push_back({double(k) / n, {{t[0], t[1], t[2]}, where.barycentric}});
  }
  for (const Segment& piece : pieces)
    for (int v : vertices_on_segment(mesh, piece)) {
      const Point& p = mesh.vertices[std::size_t(v)];
      along.push_back({((p.x - whole.a.x) * e.x + (p.y - whole.a.y) * e.y) / len2, {{v, v, v}, {1, 0, 0}}});
    }
  std::stable_sort(along.begin(), along.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  MpLine line;
  for (const auto& [t, point] : along) line.points.push_back(point);
  return line;
}

}  // namespace

MpModel build_mp_model(const MethodInput& input, const MpPrecomputeOptions& options) {
  MpModel model;
  const tiles::Raster& image = input.analysis_image;
  if (image.empty()) return model;
  model.width = image.width;
  model.height = image.height;
  const double d = std::sqrt(model.width * model.height / options.point_count);

  const FeaturePoints features = feature_points(input, model.width, model.height, d);
  ConstrainedMeshOptions mesh_options;
  mesh_options.min_angle_degrees = options.min_angle_degrees;
  mesh_options.vertex_budget = int(std::lround(options.vertex_budget_factor * options.point_count));
  model.mesh = build_constrained_mesh(model.width, model.height, features.points, features.constraints, mesh_options);

  // Every line inside the image, also one that clear_pieces left nothing of: its whole segment.
  const TriangleLocator locator(model.mesh);
  for (std::size_t line = 0; line < features.whole.size(); ++line) {
    const std::optional<Segment>& whole = features.whole[line];
    if (!whole || length(*whole) <= 0) continue;
    std::vector<Segment> pieces;
    for (std::size_t i = 0; i < features.lines.size(); ++i)
      if (features.piece_line[i] == int(line)) pieces.push_back(features.lines[i]);
    model.lines.push_back(line_points(model.mesh, locator, *whole, pieces, d));
  }

  add_objects(model, object_triangles(input, model.mesh, model.width, options), options);
  return model;
}

std::string mp_model_bytes(const MpModel& model) {
  ModelBytesWriter out;
  out.put(model.width);
  out.put(model.height);
  out.put_count(model.mesh.vertices.size());
  for (const Point& p : model.mesh.vertices) out.put(p.x), out.put(p.y);
  out.put_count(model.mesh.triangles.size());
  for (const Triangle& t : model.mesh.triangles)
    for (int v : t) out.put(std::int32_t(v));
  out.put_count(model.objects.size());
  for (const MpObject& o : model.objects) {
    out.put_count(o.vertices.size());
    for (int v : o.vertices) out.put(std::int32_t(v));
    out.put(o.pole.x), out.put(o.pole.y), out.put(o.area);
  }
  out.put_count(model.lines.size());
  for (const MpLine& l : model.lines) {
    out.put_count(l.points.size());
    for (const MpLinePoint& p : l.points) {
      for (int v : p.vertices) out.put(std::int32_t(v));
      for (double w : p.weights) out.put(w);
    }
  }
  out.put_count(model.row_object_length.size());
  for (double v : model.row_object_length) out.put(v);
  out.put_count(model.column_object_length.size());
  for (double v : model.column_object_length) out.put(v);
  return out.take();
}

MpModel parse_mp_model(std::string_view bytes) {
  ModelBytesReader in(bytes, "mp model");
  MpModel m;
  m.width = in.number();
  m.height = in.number();
  if (m.width < 0 || m.height < 0) in.fail("negative size");
  m.mesh.vertices.resize(in.count(16));
  for (Point& p : m.mesh.vertices) p.x = in.number(), p.y = in.number();
  const std::size_t nv = m.mesh.vertices.size();
  m.mesh.triangles.resize(in.count(12));
  for (Triangle& t : m.mesh.triangles)
    for (int& v : t) v = in.index(nv);
  m.objects.resize(in.count(28));
  for (MpObject& o : m.objects) {
    o.vertices.resize(in.count(4));
    for (int& v : o.vertices) v = in.index(nv);
    o.pole.x = in.number(), o.pole.y = in.number(), o.area = in.number();
  }
  m.lines.resize(in.count(4));
  for (MpLine& l : m.lines) {
    l.points.resize(in.count(36));
    for (MpLinePoint& p : l.points) {
      for (int& v : p.vertices) v = in.index(nv);
      for (double& w : p.weights) w = in.number();
    }
  }
  m.row_object_length.resize(in.count(8));
  for (double& v : m.row_object_length) v = in.number();
  m.column_object_length.resize(in.count(8));
  for (double& v : m.column_object_length) v = in.number();
  in.expect_done();
  if (m.row_object_length.size() != std::size_t(std::lround(m.height)) ||
      m.column_object_length.size() != std::size_t(std::lround(m.width)))
    in.fail("the object-length tables do not match the size");
  return m;
}

}  // namespace zoomwarp::warp
