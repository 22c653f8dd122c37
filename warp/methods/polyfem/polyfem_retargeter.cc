#include "warp/methods/polyfem/polyfem_retargeter.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "warp/core/parallel_for.h"
#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"

namespace zoomwarp::warp {

namespace {

void check_image_size(double width, double height) {
  if (!(width > 0 && height > 0)) throw std::invalid_argument("polyfem: the image size must be positive");
}

}  // namespace

PolyfemRetargeting::PolyfemRetargeting(double width, double height, PolyfemModel model)
    : width_((check_image_size(width, height), width)),
      height_(height),
      model_(std::move(model)),
      g_field_(polyfem_g_field(model_.solution)) {
  const int cells = int(model_.mesh.cells.size());
  prepared_.assign(kPreparedLevels, std::vector<CellSampling>(cells));
  parallel_for(kPreparedLevels * cells, [&](int i) {
    prepared_[i / cells][i % cells] = sample_polyfem_cell(model_.mesh, model_.solution.nodes, i % cells, i / cells);
  });
  // One sampling per cell holding both check levels' triangles (level 2's samples are level 3's).
  for (int c = 0; c < int(model_.mesh.cells.size()); ++c) {
    CellSampling both = prepared_[kCheckLevels[1]][c];
    const CellSampling& coarse = prepared_[kCheckLevels[0]][c];
    const int base = int(both.source.size());
    both.source.insert(both.source.end(), coarse.source.begin(), coarse.source.end());
    for (std::size_t i = 0; i + 1 < coarse.offset.size(); ++i) {
      both.node.insert(both.node.end(), coarse.node.begin() + coarse.offset[i], coarse.node.begin() + coarse.offset[i + 1]);
      both.weight.insert(both.weight.end(), coarse.weight.begin() + coarse.offset[i], coarse.weight.begin() + coarse.offset[i + 1]);
      both.offset.push_back(int(both.node.size()));
    }
    for (const Triangle& t : coarse.triangles) both.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
    check_.push_back(std::move(both));
  }
}

std::shared_ptr<const CellSampling> PolyfemRetargeting::sampling(int cell, int level) {
  if (level < kPreparedLevels) return {std::shared_ptr<void>(), &prepared_[level][cell]};  // not owned: lives with *this
  {
    std::lock_guard lock(deep_mutex_);
    if (auto it = deep_.find({level, cell}); it != deep_.end()) return it->second;
  }
  auto made = std::make_shared<const CellSampling>(sample_polyfem_cell(model_.mesh, model_.solution.nodes, cell, level));
  std::lock_guard lock(deep_mutex_);
  // Bounded: when full, start over (views in flight keep their shared_ptrs).
  if (deep_bytes_ + made->memory_bytes() > kDeepCacheBytes) deep_.clear(), deep_bytes_ = 0;
  auto [it, inserted] = deep_.emplace(std::make_pair(level, cell), made);
  if (inserted) deep_bytes_ += made->memory_bytes();
  return it->second;
}

Point PolyfemRetargeting::axpy_chord(int cell, int level) {
  if (level < PolyfemModel::kChordLevels) return model_.chord[cell][level];
  {
    std::lock_guard lock(deep_mutex_);
    if (auto it = deep_chord_.find({level, cell}); it != deep_chord_.end()) return it->second;
  }
  const Point delta = polyfem_chord_deviation(*sampling(cell, level + 1), g_field_);
  std::lock_guard lock(deep_mutex_);
  return deep_chord_.emplace(std::make_pair(level, cell), delta).first->second;
}

Point PolyfemRetargeting::target_chord(const Target& t, int cell, int level) {
  {
    std::lock_guard lock(t.mutex);
    if (auto it = t.chord.find({level, cell}); it != t.chord.end()) return it->second;
  }
  const Point delta = polyfem_chord_deviation(*sampling(cell, level + 1), t.displacement);
  std::lock_guard lock(t.mutex);
  return t.chord.emplace(std::make_pair(level, cell), delta).first->second;
}

bool PolyfemRetargeting::target_folds(const Target& t, int cell, int level) {
  {
    std::lock_guard lock(t.mutex);
    if (auto it = t.folds.find({level, cell}); it != t.folds.end()) return it->second;
  }
  const bool folds = polyfem_cell_folds(*sampling(cell, level), t.displacement);
  std::lock_guard lock(t.mutex);
  return t.folds.emplace(std::make_pair(level, cell), folds).first->second;
}

std::shared_ptr<const PolyfemRetargeting::Target> PolyfemRetargeting::target(double tw, double th, const StopToken* stop) {
  if (!(tw > 0 && th > 0 && std::isfinite(tw) && std::isfinite(th)))
    throw std::invalid_argument("polyfem: the target size must be positive");
  // In analysis px, where g lives.
  const double aw = model_.mesh.width, ah = model_.mesh.height;
  const double dw = tw * aw / width_ - aw, dh = th * ah / height_ - ah;
  const PolyfemSolution& s = model_.solution;
  const auto axpy = [&] {
    auto t = std::make_shared<Target>();
    t->displacement.resize(s.g_x.size());
    for (std::size_t k = 0; k < s.g_x.size(); ++k) t->displacement[k] = {dw * s.g_x[k], dh * s.g_y[k]};
    return t;
  };
  if (dw == 0 && dh == 0) return axpy();  // the identity
  std::lock_guard lock(targets_mutex_);  // single flight: a second request for it waits
  if (auto found = targets_.find({tw, th})) return *found;
  std::shared_ptr<Target> t = axpy();
  // A view's target has the image's area: outside the fold-free range det J ≤ 0 at a quadrature
  // point, so the fallback runs at once. Inside it, and for any other target, the check levels'
  // triangles decide: a chord triangle can turn over where the curved map does not (or between
  // quadrature points) — the corpus's night bridge at 9:16 did, inside the range.
  const bool image_area = std::abs(tw * th / (width_ * height_) - 1) < 1e-9;
  bool folds = image_area && !model_.fold_free.contains(tw / width_);
  for (std::size_t c = 0; !folds && c < check_.size(); ++c) folds = polyfem_cell_folds(check_[c], t->displacement);
  if (folds) {
    t->stats = polyfem_fallback(model_.mesh, s, check_, dw, dh, stop);
    t->displacement = std::move(t->stats.displacement);
    t->fallback = true;
    ++fallback_runs_;
  }
  return targets_.put({tw, th}, std::move(t));
}

void PolyfemRetargeting::append_cells(const std::vector<int>& cells, int level, const Target& target, double tw,
                                      double th, Mesh& source, std::vector<Point>& warped) {
  const double aw = model_.mesh.width, ah = model_.mesh.height;
  const double to_image_x = width_ / aw, to_image_y = height_ / ah;
  // Analysis px of the target → its image px, per axis. The right and bottom border samples are
  // put on the image's and the target's sides exactly (x = W', y = H' there by [PolyFEM eq. 12];
  // left and top: 0 by the product), which the scalings alone miss by an ulp.
  const double warp_x = tw / (tw * aw / width_), warp_y = th / (th * ah / height_);
  for (int c : cells) {
    const std::shared_ptr<const CellSampling> cell = sampling(c, level);
    const int base = int(source.vertices.size());
    for (const Point& p : cell->source)
      source.vertices.push_back({p.x == aw ? width_ : p.x * to_image_x, p.y == ah ? height_ : p.y * to_image_y});
    const std::size_t first = warped.size();
    displace_cell_samples(*cell, target.displacement, warped);
    for (std::size_t i = first; i < warped.size(); ++i) {
      const Point& p = cell->source[i - first];
      warped[i] = {p.x == aw ? tw : warped[i].x * warp_x, p.y == ah ? th : warped[i].y * warp_y};
    }
    for (const Triangle& t : cell->triangles) source.triangles.push_back({t[0] + base, t[1] + base, t[2] + base});
  }
}

std::pair<Mesh, std::vector<Point>> PolyfemRetargeting::warped_samples(double tw, double th, int level,
                                                                       const StopToken* stop) {
  const std::shared_ptr<const Target> t = target(tw, th, stop);
  std::vector<int> all(model_.mesh.cells.size());
  for (int c = 0; c < int(all.size()); ++c) all[c] = c;
  std::pair<Mesh, std::vector<Point>> out;
  append_cells(all, level, *t, tw, th, out.first, out.second);
  return out;
}

View PolyfemRetargeting::view(const ViewRequest& r) { return view(r, nullptr); }

View PolyfemRetargeting::view(const ViewRequest& r, PolyfemViewStats* stats) {
  check_view_request(r);
  check_stop(r.stop);
  // The z = 0 target of ICAZ: the screen's aspect ratio, the image's area [ICAZ §5.1].
  const ZoomGeometry g = zoom_geometry(width_, height_, r.screen_width, r.screen_height, 0, r.curve, r.frame);
  const double tw = g.target_width, th = g.target_height;
  const std::shared_ptr<const Target> t = target(tw, th, r.stop);
  check_stop(r.stop);
  const int n_cells = int(model_.mesh.cells.size());

  // The coarse view (level 0, every cell): where the centre lands, and which cells show.
  Mesh coarse;
  std::vector<Point> coarse_warped;
  std::vector<int> all(n_cells);
  for (int c = 0; c < n_cells; ++c) all[c] = c;
  append_cells(all, 0, *t, tw, th, coarse, coarse_warped);
  const Point centre{std::clamp(r.cx, 0.0, width_), std::clamp(r.cy, 0.0, height_)};
  const Point centre_warped = locate(coarse, coarse_warped, centre);
  const View coarse_view = uniform_zoom(coarse, coarse_warped, tw, th, r, centre_warped);

  // Screen px per analysis px of displacement, per axis.
  const double aw = model_.mesh.width, ah = model_.mesh.height;
  const auto [lo, hi] = std::minmax_element(coarse_warped.begin(), coarse_warped.end(),
                                            [](const Point& a, const Point& b) { return a.x < b.x; });
  const std::size_t i_lo = lo - coarse_warped.begin(), i_hi = hi - coarse_warped.begin();
  const double screen_scale = (coarse_view.screen[i_hi].x - coarse_view.screen[i_lo].x) / (hi->x - lo->x);
  const double px_x = screen_scale * width_ / aw, px_y = screen_scale * height_ / ah;
  const double dw = tw * aw / width_ - aw, dh = th * ah / height_ - ah;
  // A cell's chord error at a level, screen px: each axis's bound holds per edge, so the miss
  // vector's is their hypot.
  const auto chord_px = [&](int c, int k) {
    if (!t->fallback) {
      const Point d = axpy_chord(c, k);
      return std::hypot(std::abs(dw) * d.x * px_x, std::abs(dh) * d.y * px_y);
    }
    const Point d = target_chord(*t, c, k);
    return std::hypot(d.x * px_x, d.y * px_y);
  };

  // Visible cells: their level-0 fan on screen, grown by its chord error and a pixel.
  std::vector<int> visible;
  long fan_triangles = 0;
  {
    int v = 0;
    for (int c = 0; c < n_cells; ++c) {
      const int n = int(model_.mesh.cells[c].size());
      double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
      for (int k = 0; k < n + 1; ++k) {
        const Point& p = coarse_view.screen[v + k];
        x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
      }
      v += n + 1;  // a level-0 cell: its centroid and its n vertices
      const double margin = chord_px(c, 0) + 1;
      if (x1 + margin > 0 && x0 - margin < r.screen_width && y1 + margin > 0 && y0 - margin < r.screen_height) {
        visible.push_back(c);
        fan_triangles += n;
      }
    }
  }
  // The level: the smallest whose measured chord error is within kMaxChordErrorPx, no finer than
  // the triangle budget allows, and fold-free: a check level (checked with the target), or one
  // on which no visible cell folds (checked as views need it, kept with the target).
  int max_level = kMaxPolyfemLevel;
  while (max_level > 0 && (fan_triangles << (2 * max_level)) > kMaxExportTriangles) --max_level;
  const auto allowed = [&](int k) {
    if (k == kCheckLevels[0] || k == kCheckLevels[1]) return true;
    return std::none_of(visible.begin(), visible.end(), [&](int c) { return target_folds(*t, c, k); });
  };
  int level = 0;
  const auto worst_chord = [&](int k) {
    double worst = 0;
    for (int c : visible) worst = std::max(worst, chord_px(c, k));
    return worst;
  };
  double chord = -1;
  bool skipped = false;
  for (int k = level; k <= max_level; ++k) {
    check_stop(r.stop);
    if (!allowed(k)) {
      skipped = true;
      continue;
    }
    level = k, chord = worst_chord(k);
    if (chord <= kMaxChordErrorPx) break;
  }
  if (chord < 0) chord = worst_chord(level);  // no level allowed (a budget below the check levels)
  const bool limited = chord > kMaxChordErrorPx;

  Mesh source;
  std::vector<Point> warped;
  append_cells(visible, level, *t, tw, th, source, warped);
  check_stop(r.stop);
  View out = uniform_zoom(source, warped, tw, th, r, centre_warped);
  out.coarse_stats.converged = !t->fallback || t->stats.converged;
  out.coarse_stats.iterations = t->stats.iterations;
  if (stats)
    *stats = {level, chord, long(source.triangles.size()), int(visible.size()), limited && !skipped, limited && skipped,
              t->fallback};
  return out;
}

std::size_t PolyfemRetargeting::memory_bytes() {
  std::size_t bytes = 0;
  for (const auto& level : prepared_)
    for (const CellSampling& cell : level) bytes += cell.memory_bytes();
  std::lock_guard lock(deep_mutex_);
  return bytes + deep_bytes_ + model_.solution.stiffness.value.size() * 16 + model_.solution.g_x.size() * 16;
}

const RetargetingMethod& polyfem_method() {
  static const RetargetingMethod kMethod{
      .name = "polyfem",
      .summary = "polygonal finite elements [PolyFEM]: ~200 saliency-adaptive convex cells with quadratic serendipity "
                 "elements, E_T = ∫ s|J − I|² plus a term keeping lines straight, solved once per axis so that any aspect "
                 "is one combination (L-BFGS with per-cell rollback where that would fold), then zoomed uniformly",
      .zoom = kZoomIntoTheRetargetedImage,
      .has_mesh = true,
      .lines = "each line sampled every ≤ 4 analysis px through its cells' serendipity basis; its second differences "
               "across the line are penalised per axis (a quadratic term of ours, λ = 100)",
      .magic = {'Z', 'W', 'P', 'F', 'E', 'M', '2', 0},  // 2: L_x, L_y after K
      .reads_lines = true,
      .precompute = [](const MethodInput& input) { return polyfem_model_bytes(build_polyfem_model(input)); },
      .precompute_bytes_per_pixel = 26,  // 18-25 MB at 996×934
      .load = [](const ImageModel& model, const SignificanceMap&, std::string_view bytes) -> std::unique_ptr<Retargeter> {
        return std::make_unique<PolyfemRetargeting>(model.width, model.height, parse_polyfem_model(bytes));
      },
  };
  return kMethod;
}

}  // namespace zoomwarp::warp
