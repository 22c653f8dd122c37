#include "warp/icaz/icaz.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "warp/core/limits.h"
#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"
#include "warp/icaz/edge_map.h"
#include "warp/icaz/lod_cut.h"

namespace zoomwarp::warp {

namespace {

// The viewing area's origin along one axis: centred on c and kept inside the warped image, or,
// where the image is smaller than the viewing area (letterboxing, zoom_curve.h), centred with the
// bands a whole number of screen pixels wide — so that at scale 1 screen pixels are image pixels.
double place_on_axis(double c, double view, double target, double scale) {
  if (view >= target) return -std::floor((view - target) * scale / 2) / scale;
  return std::clamp(c - view / 2, 0.0, target - view);
}

// The affine map of a triangle onto its warped image, p ↦ A p + t: where the coarse warp puts a
// forest vertex (through its root triangle), and how much it magnifies the root's area.
struct AffineMap {
  double a = 1, b = 0, c = 0, d = 1, tx = 0, ty = 0;

  Point operator()(const Point& p) const { return {a * p.x + b * p.y + tx, c * p.x + d * p.y + ty}; }
  double area_ratio() const { return a * d - b * c; }
};

// The map taking triangle (s0, s1, s2) to (w0, w1, w2): A = [w1 − w0, w2 − w0] [s1 − s0, s2 − s0]⁻¹.
AffineMap triangle_map(const Point& s0, const Point& s1, const Point& s2, const Point& w0, const Point& w1,
                       const Point& w2) {
  const double e = s1.x - s0.x, f = s2.x - s0.x, g = s1.y - s0.y, h = s2.y - s0.y, det = e * h - f * g;
  const double i00 = h / det, i01 = -f / det, i10 = -g / det, i11 = e / det;  // [s1 − s0, s2 − s0]⁻¹
  const double p = w1.x - w0.x, q = w2.x - w0.x, r = w1.y - w0.y, u = w2.y - w0.y;
  AffineMap m;
  m.a = p * i00 + q * i10, m.b = p * i01 + q * i11, m.c = r * i00 + u * i10, m.d = r * i01 + u * i11;
  m.tx = w0.x - m.a * s0.x - m.b * s0.y, m.ty = w0.y - m.c * s0.x - m.d * s0.y;
  return m;
}

// Keeps a cache under 64 entries by dropping the least recently used.
template <class Cache>
void make_room(Cache& cache) {
  if (cache.size() < 64) return;
  cache.erase(std::min_element(cache.begin(), cache.end(), [](const auto& a, const auto& b) {
    return a.second.last_used < b.second.last_used;
  }));
}

// The triangles whose warped bounding box meets `box` (x0, y0, x1, y1).
std::vector<char> triangles_near(const Mesh& mesh, const std::vector<Point>& warped, const std::array<double, 4>& box) {
  std::vector<char> out(mesh.triangles.size(), 0);
  for (std::size_t f = 0; f < mesh.triangles.size(); ++f) {
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (int v : mesh.triangles[f]) {
      x0 = std::min(x0, warped[v].x), x1 = std::max(x1, warped[v].x);
      y0 = std::min(y0, warped[v].y), y1 = std::max(y1, warped[v].y);
    }
    out[f] = x1 >= box[0] && x0 <= box[2] && y1 >= box[1] && y0 <= box[3];
  }
  return out;
}

// The chosen triangles of a mesh as a mesh of their own, for a local solve. Vertices shared with
// a triangle not chosen are pinned, so the solved part joins the rest of the warp without a seam.
struct Submesh {
  Mesh mesh;
  std::vector<int> vertex;    // submesh vertex → mesh vertex
  std::vector<int> triangle;  // submesh triangle → mesh triangle
  std::vector<int> pinned;    // submesh vertices
};

Submesh submesh(const Mesh& mesh, const std::vector<char>& chosen) {
  Submesh out;
  std::vector<int> index(mesh.vertices.size(), -1);
  std::vector<char> outside(mesh.vertices.size(), 0);
  for (int f = 0; f < int(mesh.triangles.size()); ++f) {
    if (!chosen[f]) {
      for (int v : mesh.triangles[f]) outside[v] = 1;
      continue;
    }
    Triangle t;
    for (int k = 0; k < 3; ++k) {
      int& i = index[mesh.triangles[f][k]];
      if (i < 0) i = int(out.vertex.size()), out.vertex.push_back(mesh.triangles[f][k]);
      t[k] = i;
    }
    out.mesh.triangles.push_back(t);
    out.triangle.push_back(f);
  }
  for (int v : out.vertex) {
    out.mesh.vertices.push_back(mesh.vertices[v]);
    if (outside[v]) out.pinned.push_back(index[v]);
  }
  return out;
}

}  // namespace

struct Icaz::CoarseWarp {
  std::vector<Point> positions;  // of the coarsest mesh's vertices
  std::vector<AffineMap> maps;   // of its triangles (the forest's roots)
};

Icaz::Icaz(ImageModel model, const IcazOptions& options)
    : model_(std::move(model)),
      profile_(warp::significance_profile(model_.significance, model_.edits, model_.width, model_.height)),
      options_(options),
      coarse_(model_.coarse.mesh, triangle_weights(model_.coarse.mesh, model_.significance, model_.w_min),
              model_.width, model_.height, model_.straight_lines),
      forest_(model_.forest),
      root_cut_(forest_) {
  node_mean_.assign(model_.node_mean.begin(), model_.node_mean.end());
  node_mean_.resize(std::size_t(forest_.kept_nodes()), std::numeric_limits<double>::quiet_NaN());
  // Significance is mapped to weights by the range of the coarsest triangles' means.
  sig_lo_ = std::numeric_limits<double>::infinity(), sig_hi_ = -sig_lo_;
  for (int r = 0; r < forest_.root_count(); ++r) {
    const double mean = node_mean(r, true);
    sig_lo_ = std::min(sig_lo_, mean), sig_hi_ = std::max(sig_hi_, mean);
  }
  const ImageModel& m = model_;
  model_bytes_ = m.significance.values.capacity() * sizeof(float) + m.forest.memory_bytes() +
                 m.node_mean.capacity() * sizeof(float) + m.coarse.mesh.vertices.capacity() * sizeof(Point) +
                 m.coarse.mesh.triangles.capacity() * sizeof(Triangle);
  count_forest_bytes();
}

Icaz::~Icaz() = default;

std::size_t Icaz::memory_bytes() const noexcept {
  return model_bytes_ + forest_bytes_.load(std::memory_order_relaxed) + coarse_bytes_.load(std::memory_order_relaxed);
}

void Icaz::count_forest_bytes() {
  forest_bytes_.store(forest_.memory_bytes() + node_mean_.capacity() * sizeof(double), std::memory_order_relaxed);
}

void Icaz::count_coarse_bytes() {
  std::size_t bytes = 0;
  for (const auto& [size, cached] : coarse_cache_)
    bytes += cached.warp->positions.capacity() * sizeof(Point) + cached.warp->maps.capacity() * sizeof(AffineMap);
  for (const auto& [k, cached] : anchors_) bytes += cached.positions.capacity() * sizeof(Point);
  coarse_bytes_.store(bytes, std::memory_order_relaxed);
}

double Icaz::node_mean(int node, bool grow) {
  if (!grow && (node >= int(node_mean_.size()) || std::isnan(node_mean_[node]))) throw ForestGrowthNeeded();
  if (node >= int(node_mean_.size())) node_mean_.resize(std::size_t(forest_.node_count()), std::numeric_limits<double>::quiet_NaN());
  double& mean = node_mean_[node];
  if (std::isnan(mean)) {
    const auto& t = forest_.corners(node);
    const auto& v = forest_.vertices();
    mean = mean_over_triangle(model_.significance, v[t[0]], v[t[1]], v[t[2]]);
  }
  return mean;
}

double Icaz::node_weight(int node, bool grow) {
  const double mean = node_mean(node, grow);
  const double range = sig_hi_ - sig_lo_;
  const double unit = range > 0 ? std::clamp((mean - sig_lo_) / range, 0.0, 1.0) : 1.0;
  return model_.w_min + (1 - model_.w_min) * unit;
}

// Accuracy is judged on screen: iterate until no vertex moves more than 0.05 screen pixels.
// Oblique lines keep the normal of the start positions, so a solve is one factorization and
// accelerated iterations whatever the lines (bounded cost, limits.h): the coarse warp starts from
// the affine stretch, which keeps lines straight and gives their orientation, and the fine level
// from the coarse result, whose lines are straight already [ICAZ §6.2, nested iteration].
WarpOptions Icaz::solve_options(const ShapeWarp& coarse, const StopToken* stop) {
  WarpOptions o;
  o.fixed_line_normals = true;
  o.stop = stop;
  o.rotation_weight = coarse.factored_once() ? 0 : kRotationWeight;
  return o;
}

WarpOptions Icaz::tolerance_for(const ZoomGeometry& g, const StopToken* stop) const {
  WarpOptions o = solve_options(coarse_, stop);
  o.tolerance = 0.05 / g.screen_scale;
  return o;
}

std::shared_ptr<const Icaz::CoarseWarp> Icaz::coarse_warp(const ZoomGeometry& g, WarpResult* stats,
                                                          const StopToken* stop) {
  const auto key = std::make_pair(std::llround(g.target_width * 1000), std::llround(g.target_height * 1000));
  std::lock_guard lock(coarse_mu_);
  if (auto it = coarse_cache_.find(key); it != coarse_cache_.end()) {
    it->second.last_used = ++coarse_clock_;
    return it->second.warp;
  }
  if (options_.before_coarse_solve) options_.before_coarse_solve();
  const WarpOptions options = tolerance_for(g, stop);
  bool close_enough = false;
  const std::vector<Point> start = coarse_start(g.target_width, g.target_height, options.tolerance, stop, &close_enough);
  if (close_enough) {  // taken as it is (its boundary set exactly), if it folds nothing
    WarpOptions as_is = options;
    as_is.max_iterations = 0, as_is.fold_guard = false;
    *stats = coarse_.solve(g.target_width, g.target_height, as_is, start);
    stats->converged = stats->inverted == 0;
  }
  if (!close_enough || !stats->converged) *stats = coarse_.solve(g.target_width, g.target_height, options, start);
  auto warp = std::make_shared<CoarseWarp>();
  warp->positions = stats->positions;
  const Mesh& roots = model_.coarse.mesh;
  warp->maps.reserve(roots.triangles.size());
  for (const Triangle& t : roots.triangles)
    warp->maps.push_back(triangle_map(roots.vertices[t[0]], roots.vertices[t[1]], roots.vertices[t[2]],
                                      warp->positions[t[0]], warp->positions[t[1]], warp->positions[t[2]]));
  make_room(coarse_cache_);
  coarse_cache_.emplace(key, CachedCoarse{warp, ++coarse_clock_});
  count_coarse_bytes();
  return warp;
}

// Every zoom level asks for a new target size, and from the affine stretch the coarse warp needs
// 6–8 local–global iterations (14 for a 4:1 panorama on a portrait screen). Started instead from
// the warps at the two anchor aspects around the target's — a geometric grid of aspects 5 %
// apart through the image's own, same area — each scaled to the target and the two blended
// linearly in log aspect, it needs 1 (world map, boats, a 4:1 panorama and a tall interior on
// 480×360 and 360×640; within 0.05 screen px of the warp from the affine stretch; a 10 % grid
// needed 1–2 there but up to 4 on the 315 MP mosaic, whose target pixels are small) — and often
// none: the blend strays from the answer most at the middle between two anchors, so one
// iteration from there is measured once per pair (anchor_gap), and where it moved less than half
// the view's tolerance the blend is the coarse warp as it is (`close_enough`). Where it moved
// more (large images near z = 1, where the tolerance in target px is smallest), the grid is
// halved, up to twice (anchors 1.25 % apart), before one iteration is taken. Nested iteration
// across zoom levels rather than resolutions [ICAZ §6.2]. Anchors depend on nothing but the
// image, so a view stays a function of its request whatever was asked before; each is solved
// once (from the affine stretch, to 0.01 px) and kept like a cached warp. The target at the
// image's aspect (z = 1) is anchor 0 itself, whose start is the identity: still exact. Where an
// anchor needed the fold-over guard (a 4:1 panorama on a portrait screen near z = 0), its
// reweighted warp is no nearer the answer than the affine stretch, which is used instead.
std::vector<Point> Icaz::coarse_start(double tw, double th, double tolerance, const StopToken* stop,
                                      bool* close_enough) {
  const double u = std::log((tw / th) / (model_.width / model_.height)) / kFinestAnchorStep;
  std::vector<Point> start;
  *close_enough = false;
  for (int level = 0; level <= kAnchorLevels && !*close_enough; ++level) {
    const int stride = 1 << (kAnchorLevels - level);
    const double below = stride * std::floor(u / stride);
    start = anchor_blend(u, stride, tw, th, stop);
    if (start.empty()) break;
    *close_enough = (u == below ? kAnchorTolerance : anchor_gap(int(below), level, stop)) <= tolerance / 2;
  }
  return start;
}

std::vector<Point> Icaz::anchor_blend(double u, int stride, double tw, double th, const StopToken* stop) {
  const double below = stride * std::floor(u / stride), t = (u - below) / stride;
  std::vector<Point> out(model_.coarse.mesh.vertices.size());
  for (int side = 0; side < 2; ++side) {
    const double weight = side ? t : 1 - t;
    if (weight == 0) continue;
    const int index = int(below) + side * stride;
    const CachedWarp& warp = anchor(index, stop);
    if (warp.guarded) return {};
    const double sx = weight * tw / anchor_width(index), sy = weight * th / anchor_height(index);
    for (std::size_t i = 0; i < out.size(); ++i) out[i].x += sx * warp.positions[i].x, out[i].y += sy * warp.positions[i].y;
  }
  return out;
}

double Icaz::anchor_gap(int j, int level, const StopToken* stop) {
  if (const double gap = anchor(j, stop).gap[level]; !std::isnan(gap)) return gap;
  const int stride = 1 << (kAnchorLevels - level);
  const double middle_u = j + 0.5 * stride;
  const double tw = model_.width * std::exp(middle_u * kFinestAnchorStep / 2);
  const double th = model_.height * std::exp(-middle_u * kFinestAnchorStep / 2);
  const std::vector<Point> middle = anchor_blend(middle_u, stride, tw, th, stop);
  WarpOptions o = solve_options(coarse_, stop);
  o.max_iterations = 1, o.fold_guard = false;
  const WarpResult step = coarse_.solve(tw, th, o, middle);
  double gap = 0;
  for (std::size_t i = 0; i < middle.size(); ++i)
    gap = std::max(gap, std::hypot(step.positions[i].x - middle[i].x, step.positions[i].y - middle[i].y));
  return anchors_.find(j)->second.gap[level] = gap;
}

double Icaz::anchor_width(int j) const { return model_.width * std::exp(j * kFinestAnchorStep / 2); }
double Icaz::anchor_height(int j) const { return model_.height * std::exp(-j * kFinestAnchorStep / 2); }

const Icaz::CachedWarp& Icaz::anchor(int j, const StopToken* stop) {
  if (auto it = anchors_.find(j); it != anchors_.end()) {
    it->second.last_used = ++coarse_clock_;
    return it->second;
  }
  WarpOptions o = solve_options(coarse_, stop);
  o.tolerance = kAnchorTolerance;
  WarpResult r = coarse_.solve(anchor_width(j), anchor_height(j), o);
  make_room(anchors_);
  const bool guarded = r.guard_rounds > 0 || r.affine_blend > 0;
  CachedWarp entry{std::move(r.positions), ++coarse_clock_, guarded};
  entry.gap.fill(std::numeric_limits<double>::quiet_NaN());
  const CachedWarp& stored = anchors_.emplace(j, std::move(entry)).first->second;
  count_coarse_bytes();
  return stored;
}

// Runs work(false) holding the forest lock shared; if it needs the forest to grow, runs
// work(true) again holding it exclusively, after forgetting lazy nodes past the cap (a new epoch).
template <class Work>
auto Icaz::with_forest(Work work) {
  {
    std::shared_lock lock(forest_mu_);
    try {
      return work(false);
    } catch (const ForestGrowthNeeded&) {
    }
  }
  std::unique_lock lock(forest_mu_);
  struct Recount {  // the forest may have grown or shrunk, also if work throws
    Icaz* self;
    ~Recount() { self->count_forest_bytes(); }
  } recount{this};
  if (forest_.node_count() > options_.max_forest_nodes) {
    forest_.forget_lazy_nodes();
    node_mean_.resize(std::size_t(forest_.kept_nodes()));
    ++forest_epoch_;
  }
  return work(true);
}

View Icaz::view(const ViewRequest& req) {
  check_view_request(req);
  check_stop(req.stop);
  return with_forest([&](bool grow) { return view_in(req, grow); });
}

Geomorph Icaz::geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view) {
  check_view_request(from);
  check_view_request(to);
  return with_forest([&](bool grow) {
    const View a = view_in(from, grow), b = view_in(to, grow);
    Geomorph g = geomorph_in(a, b, to.stop, grow);
    if (to_view) *to_view = b;
    return g;
  });
}

View Icaz::view_in(const ViewRequest& req, bool grow) {
  check_stop(req.stop);
  View out;
  out.forest_epoch = forest_epoch_;
  const ZoomGeometry g = zoom_geometry(model_.width, model_.height, req.screen_width, req.screen_height, req.zoom, req.curve,
                                        req.frame);
  out.geometry = g;
  const Point centre{std::clamp(req.cx, 0.0, model_.width), std::clamp(req.cy, 0.0, model_.height)};

  // Coarse level: warp, then place the viewing area on the view centre, inside the image.
  const std::shared_ptr<const CoarseWarp> coarse_warped = coarse_warp(g, &out.coarse_stats, req.stop);
  const std::vector<Point>& coarse = coarse_warped->positions;
  check_stop(req.stop);
  auto place = [&](const Point& c) {
    return Point{place_on_axis(c.x, g.view_width, g.target_width, g.screen_scale),
                 place_on_axis(c.y, g.view_height, g.target_height, g.screen_scale)};
  };
  Point origin = place(locate(model_.coarse.mesh, coarse, centre));

  // Warped position of any forest vertex through its root triangle's affine map.
  const std::vector<AffineMap>& root_map = coarse_warped->maps;
  auto warped_by_coarse = [&](int v) { return root_map[forest_.root_of_vertex(v)](forest_.vertices()[v]); };

  // Refinement: split what touches the viewing area (with a margin of one screen triangle) and
  // is larger on screen than the threshold. A cap bounds the work whatever the input.
  LodCut cut = root_cut_;
  cut.set_growable(grow);
  const double s2 = g.screen_scale * g.screen_scale;
  const double max_area = std::max(req.max_screen_area, double(req.screen_width) * req.screen_height /
                                                            options_.max_screen_triangles);
  const double margin = std::sqrt(max_area) / g.screen_scale;
  auto wants_split = [&](int node) {
    if (forest_.area(node) * std::max(root_map[forest_.root_of(node)].area_ratio(), 0.0) * s2 <= max_area) return false;
    double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
    for (int v : forest_.corners(node)) {
      const Point p = warped_by_coarse(v);
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
    return x1 >= origin.x - margin && x0 <= origin.x + g.view_width + margin && y1 >= origin.y - margin &&
           y0 <= origin.y + g.view_height + margin;
  };
  constexpr int kMaxSplits = 40000;
  std::vector<int> queue = cut.nodes(), split;
  for (std::size_t i = 0; i < queue.size() && int(split.size()) < kMaxSplits; ++i) {
    if (i % 1024 == 0) check_stop(req.stop);
    const int n = queue[i];
    if (!cut.active(n) || !wants_split(n)) continue;
    const std::size_t before = split.size();
    cut.refine(n, &split);
    for (std::size_t k = before; k < split.size(); ++k)
      for (int c : forest_.existing_children(split[k])) queue.push_back(c);
  }

  // Fine level, from the coarse result (nested iteration). Only the part of the refined mesh near
  // the viewing area is solved, with the coarse result pinned around it: far from the screen the
  // fine warp would differ from the coarse one by what nobody sees, and solving there would cost
  // as much as the whole coarsest mesh again on every view.
  out.source = cut.mesh(&out.forest_vertex, &out.nodes);
  for (int v : out.forest_vertex) out.warped.push_back(warped_by_coarse(v));
  if (split.empty()) {  // nothing refined: the fine mesh is the coarse one, already warped
    out.fine_stats = out.coarse_stats;
  } else {
    const double pad = std::max(margin, options_.solve_margin * std::max(g.view_width, g.view_height));
    std::vector<char> chosen = triangles_near(out.source, out.warped, {origin.x - pad, origin.y - pad,
                                                                      origin.x + g.view_width + pad, origin.y + g.view_height + pad});
    const Submesh local = submesh(out.source, chosen);
    std::vector<double> weights;
    std::vector<Point> initial;
    for (int f : local.triangle) weights.push_back(node_weight(out.nodes[f], grow));
    check_stop(req.stop);
    for (int v : local.vertex) initial.push_back(out.warped[v]);
    // Each line is held only in its parts inside the solved region — a line is not solved whole
    // [ICAZ §5.2: the fine level only near the viewing area]: the rest of it lies outside,
    // pinned on the coarse warp's (straight) line, and so do a part's pinned ends, so the visible
    // part stays straight while the cost of a view does not grow with the lines' total length.
    const ShapeWarp fine(local.mesh, std::move(weights), model_.width, model_.height, model_.straight_lines,
                         local.pinned);
    out.fine_stats = fine.solve(g.target_width, g.target_height, tolerance_for(g, req.stop), initial);
    for (std::size_t i = 0; i < local.vertex.size(); ++i) out.warped[local.vertex[i]] = out.fine_stats.positions[i];
  }
  out.fine_stats.positions.clear();  // in the submesh's numbering; `warped` has them all
  const Point c = locate(out.source, out.warped, centre);
  origin = place(c);
  out.view_x = origin.x, out.view_y = origin.y;
  out.centre_clamped = std::abs(c.x - g.view_width / 2 - origin.x) > 1e-6 || std::abs(c.y - g.view_height / 2 - origin.y) > 1e-6;

  for (const Point& p : out.warped) out.screen.push_back({(p.x - origin.x) * g.screen_scale, (p.y - origin.y) * g.screen_scale});
  out.visible = visible_triangles(out.source, out.screen, req.screen_width, req.screen_height);
  return out;
}

View Icaz::traditional(const ViewRequest& r) {
  check_view_request(r);
  const Point centre{std::clamp(r.cx, 0.0, model_.width), std::clamp(r.cy, 0.0, model_.height)};
  View view = uniform_zoom(model_.coarse.mesh, model_.coarse.mesh.vertices, model_.width, model_.height, r, centre);
  view.uniform = true;  // the source is its own warp
  return view;
}

Geomorph Icaz::geomorph(const View& from, const View& to, const StopToken* stop) {
  return with_forest([&](bool grow) {
    if (from.forest_epoch != forest_epoch_ || to.forest_epoch != forest_epoch_)
      throw std::invalid_argument("views from an earlier forest epoch");
    return geomorph_in(from, to, stop, grow);
  });
}

Geomorph Icaz::geomorph_in(const View& from, const View& to, const StopToken* stop, bool grow) {
  check_stop(stop);
  // Split, coarsest first, every node that is a strict ancestor of a node of either cut; the
  // dependents that refine() adds keep the result conforming.
  std::vector<int> ancestors;
  FlatMap<int> depth;  // of each ancestor, measured once (not per comparison)
  depth.reserve(from.nodes.size() + to.nodes.size());
  for (const View* v : {&from, &to})
    for (int n : v->nodes)
      for (int p = forest_.parent(n); p >= 0 && depth.emplace(std::uint32_t(p), 0).second; p = forest_.parent(p))
        ancestors.push_back(p);
  for (int a : ancestors)
    for (int p = a; p >= 0; p = forest_.parent(p)) ++*depth.find(std::uint32_t(a));
  std::sort(ancestors.begin(), ancestors.end(),
            [&](int a, int b) { return *depth.find(std::uint32_t(a)) < *depth.find(std::uint32_t(b)); });
  LodCut cut = root_cut_;
  cut.set_growable(grow);
  for (int n : ancestors) cut.refine(n);
  check_stop(stop);

  Geomorph g;
  g.source = cut.mesh(&g.forest_vertex);
  // A vertex a view has keeps that view's position; one it lacks (finer than its cut) is placed
  // by the affine map of the view's triangle holding it — exactly where that view draws it.
  auto positions = [&](const View& v) {
    FlatMap<int> index;  // forest vertex → the view's vertex
    index.reserve(v.forest_vertex.size());
    for (int i = 0; i < int(v.forest_vertex.size()); ++i) index.emplace(std::uint32_t(v.forest_vertex[i]), i);
    const TriangleLocator where(v.source);
    std::vector<Point> out;
    out.reserve(g.forest_vertex.size());
    for (std::size_t i = 0; i < g.forest_vertex.size(); ++i) {
      if (i % 256 == 0) check_stop(stop);
      const Point& p = g.source.vertices[i];
      const int* found = index.find(std::uint32_t(g.forest_vertex[i]));
      out.push_back(found ? v.screen[*found] : locate(v.source, v.screen, p, where.find(p)));
    }
    return out;
  };
  g.from = positions(from);
  g.to = positions(to);
  return g;
}

}  // namespace zoomwarp::warp
