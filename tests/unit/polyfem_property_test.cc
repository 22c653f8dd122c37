// method=polyfem against issue 15's acceptance, as properties of what the retargeter serves
// (warp/methods/polyfem/polyfem_retargeter.h) on models built and stored as ingest does
// (polyfem.<saliency>.bin, parsed back) — from the four samples with both saliency kinds — at
// targets of the image's area at the aspects 9:16, 1:1, 16:9 and 3:1, and in views on phone,
// desktop and extreme screens (the extreme ones need the fallback on most images):
//   - no folds: no triangle of the whole image sampled at levels 2 and 3, and none a view emits,
//     turns over;
//   - the boundary lies on the target rectangle [PolyFEM eq. 12]: samples on the source border on
//     their side to 1e-9 px, corners exact, so the warped samples tile the target (area sum);
//   - important cells keep their shape [PolyFEM eq. 11, s = 0.1 + 0.9·saliency]: the top tenth
//     of the cells by saliency have a smaller mean shape residual (the comparison's object-shape
//     metric, warp/compare/metrics.h similarity_fit_residual, over the cell's level-2 samples)
//     than the bottom half;
//   - the image's own aspect is the identity bit for bit, and inside the model's fold-free range
//     the fallback runs exactly where the axpy turns a check level's triangle over; near the
//     range's ends no triangle folds;
//   - the chord error as a client sees it: every emitted triangle edge's screen midpoint lies
//     within 0.5 px (PolyfemRetargeting::kMaxChordErrorPx) of the deformation evaluated exactly at
//     its source midpoint, or within the reported bound where the triangle budget capped the level
//     or (a fallback target's views) the fallback's displacement folds on the finer levels —
//     checked on at least one fallback view per model (a screen outside its fold-free range);
//   - lines stay straight (issue 30): on a phone both ways up at zoom 0 every detected line at
//     least 8 screen px long lies within 2 px of its chord, and the triangles' rotation p95 is at
//     most 10°.
// And [PolyFEM §4.5]'s fallback end to end (METHODS §3: "energy non-increasing, no overlap after a
// step"; the per-step property is lbfgs_rollback.h's, tested with it): from the uniform stretch
// to an energy below it and no lower than the axpy's unconstrained minimum, no triangle of its
// check samplings turned over, the border exactly where eq. 12 fixes it, and deterministic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "tests/support/analysed_image.h"
#include "tests/support/sample_cases.h"
#include "warp/compare/metrics.h"
#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"
#include "warp/core/zoom_curve.h"
#include "warp/methods/polyfem/polyfem_export.h"
#include "warp/methods/polyfem/polyfem_fallback.h"
#include "warp/methods/polyfem/polyfem_retargeter.h"

namespace zoomwarp {
namespace {

using warp::CellSampling;
using warp::PolyfemModel;
using warp::PolyfemRetargeting;
using warp::PolyfemViewStats;
using warp::Point;
using warp::Saliency;
using warp::View;

constexpr double kOnSide = 1e-9;      // px, a border sample from its side
constexpr double kTiles = 1e-9;       // relative, the warped area from the target's
constexpr double kChordSlack = 1e-6;  // px, rounding in the chord comparison
constexpr int kShapeLevel = 2;        // the samples a cell's shape residual is measured on

struct Aspect {
  const char* name;
  double ratio;  // W'/H'
};
constexpr Aspect kAspects[] = {{"9:16", 9.0 / 16}, {"1:1", 1}, {"16:9", 16.0 / 9}, {"3:1", 3}};

struct Screen {
  int w, h;
};
// Phones both ways up, a desktop, and extreme ones: their aspects lie outside the fold-free
// range of most models.
constexpr Screen kScreens[] = {{360, 640}, {640, 360}, {1280, 800}, {900, 300}, {100, 1000}, {1000, 100}};
constexpr double kZooms[] = {0, 0.5, 1};

// The analysed images, each made once per process (gtest runs the tests on one thread).
const testing::AnalysedImage& analysed(const std::string& name) {
  static std::map<std::string, testing::AnalysedImage> cache;
  auto it = cache.find(name);
  if (it == cache.end()) it = cache.emplace(name, testing::analyse_sample(name)).first;
  return it->second;
}

// An image's saliency map of one kind and a retargeter on its polyfem model as the server loads
// it (built, stored, parsed).
struct Subject {
  const testing::AnalysedImage* image = nullptr;
  warp::SignificanceMap map;
  std::unique_ptr<PolyfemRetargeting> retargeter;
  double width = 0, height = 0;  // image px
  const PolyfemModel& model() const { return retargeter->model(); }
};
Subject& subject(const std::string& name, Saliency kind) {
  static std::map<std::pair<std::string, Saliency>, Subject> cache;
  auto it = cache.find({name, kind});
  if (it == cache.end()) {
    Subject s;
    s.image = &analysed(name);
    s.map = s.image->saliency(kind);
    s.width = s.image->model.width, s.height = s.image->model.height;
    PolyfemModel m =
        warp::parse_polyfem_model(warp::polyfem_model_bytes(warp::build_polyfem_model(s.image->input(kind, s.map))));
    s.retargeter = std::make_unique<PolyfemRetargeting>(s.width, s.height, std::move(m));
    it = cache.emplace(std::pair{name, kind}, std::move(s)).first;
  }
  return it->second;
}

// The target of the image's area at an aspect, W'·H' = W·H, as a view asks for it.
struct Target {
  double w = 0, h = 0;
};
Target equal_area(const Subject& s, double ratio) {
  return {std::sqrt(s.width * s.height * ratio), std::sqrt(s.width * s.height / ratio)};
}

// The cells sampled at one level here, as the retargeter samples them (polyfem_export.h), on
// demand.
class Samplings {
 public:
  Samplings(const PolyfemModel& m, int level) : model_(m), level_(level) {}
  const CellSampling& operator[](int cell) {
    auto it = cells_.find(cell);
    if (it == cells_.end())
      it = cells_.emplace(cell, warp::sample_polyfem_cell(model_.mesh, model_.solution.nodes, cell, level_)).first;
    return it->second;
  }

 private:
  const PolyfemModel& model_;
  const int level_;
  std::map<int, CellSampling> cells_;
};

// Analysis px → image px, as the retargeter scales its source samples: those on the right and
// bottom border exactly on the image's.
Point to_image(const Subject& s, const Point& p) {
  const double aw = s.model().mesh.width, ah = s.model().mesh.height;
  return {p.x == aw ? s.width : p.x * (s.width / aw), p.y == ah ? s.height : p.y * (s.height / ah)};
}

// The cell holding p (analysis px) most deeply.
int cell_holding(const warp::PolygonMesh& mesh, const Point& p) {
  int best = -1;
  double depth = -1e300;
  for (int c = 0; c < int(mesh.cells.size()); ++c) {
    double inside = 1e300;
    const std::vector<int>& ids = mesh.cells[c];
    for (std::size_t i = 0; i < ids.size(); ++i) {
      const Point &a = mesh.vertices[ids[i]], &b = mesh.vertices[ids[(i + 1) % ids.size()]];
      inside = std::min(inside, warp::signed_area2(a, b, p) / std::hypot(b.x - a.x, b.y - a.y));
    }
    if (inside > depth) depth = inside, best = c;
  }
  return best;
}

// A run of a mesh the retargeter emitted: one cell's samples and triangles.
struct CellRun {
  int cell = 0;
  int first_vertex = 0, first_triangle = 0;
};

// The cells of a mesh the retargeter emitted at `level` (warped_samples, a view): the retargeter
// appends one cell after another (polyfem_export.h), so each run is recognised by the cell
// holding its first triangle and checked sample by sample and triangle by triangle against the
// cell sampled here — the retargeter's API names no cells.
std::vector<CellRun> cell_runs(const Subject& s, Samplings& cells, const warp::Mesh& emitted) {
  const warp::PolygonMesh& mesh = s.model().mesh;
  std::vector<CellRun> runs;
  int v = 0, f = 0;
  while (f < int(emitted.triangles.size())) {
    const warp::Triangle& t = emitted.triangles[f];
    Point inside{0, 0};
    for (int k : t) inside = {inside.x + emitted.vertices[k].x / 3, inside.y + emitted.vertices[k].y / 3};
    const int c = cell_holding(mesh, {inside.x * mesh.width / s.width, inside.y * mesh.height / s.height});
    const CellSampling& cell = cells[c];
    EXPECT_LE(v + cell.source.size(), emitted.vertices.size());
    EXPECT_LE(f + cell.triangles.size(), emitted.triangles.size());
    if (v + cell.source.size() > emitted.vertices.size() || f + cell.triangles.size() > emitted.triangles.size())
      return {};
    for (std::size_t i = 0; i < cell.source.size(); ++i) {
      const Point p = to_image(s, cell.source[i]), &q = emitted.vertices[v + i];
      if (p.x != q.x || p.y != q.y) {
        ADD_FAILURE() << "cell " << c << " sample " << i << " is not the retargeter's";
        return {};
      }
    }
    for (std::size_t i = 0; i < cell.triangles.size(); ++i)
      for (int k = 0; k < 3; ++k)
        if (cell.triangles[i][k] + v != emitted.triangles[f + i][k]) {
          ADD_FAILURE() << "cell " << c << " triangle " << i << " is not the retargeter's";
          return {};
        }
    runs.push_back({c, v, f});
    v += int(cell.source.size()), f += int(cell.triangles.size());
  }
  EXPECT_EQ(v, int(emitted.vertices.size()));
  return runs;
}

// Counted here from the positions.
int fold_overs(const warp::Mesh& mesh, const std::vector<Point>& q) {
  int n = 0;
  for (const auto& t : mesh.triangles) n += warp::signed_area2(q[t[0]], q[t[1]], q[t[2]]) <= 0;
  return n;
}

warp::ViewRequest request(const Screen& screen, double zoom, Point centre) {
  warp::ViewRequest r;
  r.zoom = zoom, r.cx = centre.x, r.cy = centre.y;
  r.screen_width = screen.w, r.screen_height = screen.h;
  return r;
}

// One image (a file in samples/) and a saliency kind.
class PolyfemProperty : public ::testing::TestWithParam<testing::SampleCase> {
 protected:
  Subject& tested() const { return subject(GetParam().image, GetParam().kind); }
  std::string label() const {
    const std::string image = GetParam().image;
    return image.substr(0, image.find('_')) + "/" + std::string(warp::saliency_name(GetParam().kind));
  }
};

TEST_P(PolyfemProperty, NoTriangleFolds) {
  Subject& s = tested();
  PolyfemRetargeting& r = *s.retargeter;
  for (const Aspect& a : kAspects) {
    const Target t = equal_area(s, a.ratio);
    for (int level : {2, 3}) {
      const auto [mesh, warped] = r.warped_samples(t.w, t.h, level);
      EXPECT_EQ(fold_overs(mesh, warped), 0) << a.name << " level " << level;
    }
  }
  for (const Screen& screen : kScreens)
    for (double zoom : kZooms) {
      PolyfemViewStats stats;
      const View v = r.view(request(screen, zoom, {s.width / 2, s.height / 2}), &stats);
      ASSERT_FALSE(v.source.triangles.empty());
      EXPECT_EQ(fold_overs(v.source, v.warped), 0)
          << screen.w << "x" << screen.h << " z " << zoom << (stats.fallback ? " (fallback)" : "");
    }
  std::printf("[ polyfem  ] %-18s fold-free aspect range of the axpy (%.3f, %.3f) × the image's\n", label().c_str(),
              s.model().fold_free.low, s.model().fold_free.high);
}

TEST_P(PolyfemProperty, BoundaryOnTheTargetRectangle) {
  Subject& s = tested();
  const warp::PolygonMesh& mesh = s.model().mesh;
  Samplings cells(s.model(), kShapeLevel);
  for (const Aspect& a : kAspects) {
    SCOPED_TRACE(a.name);
    const Target t = equal_area(s, a.ratio);
    const auto [emitted, warped] = s.retargeter->warped_samples(t.w, t.h, kShapeLevel);
    double off_side = 0, area = 0;
    int on_border = 0, corners = 0, corners_off = 0;
    for (const CellRun& run : cell_runs(s, cells, emitted)) {
      const CellSampling& cell = cells[run.cell];
      for (std::size_t i = 0; i < cell.source.size(); ++i) {
        const Point &p = cell.source[i], &q = warped[run.first_vertex + i];
        const bool left = p.x == 0, right = p.x == mesh.width, top = p.y == 0, bottom = p.y == mesh.height;
        if (left || right) off_side = std::max(off_side, std::abs(q.x - (left ? 0 : t.w)));
        if (top || bottom) off_side = std::max(off_side, std::abs(q.y - (top ? 0 : t.h)));
        on_border += left || right || top || bottom;
        if ((left || right) && (top || bottom)) {
          ++corners;
          corners_off += q.x != (left ? 0 : t.w) || q.y != (top ? 0 : t.h);
        }
      }
    }
    for (const auto& tri : emitted.triangles) area += warp::signed_area(emitted, tri, warped);
    EXPECT_LE(off_side, kOnSide) << on_border << " border samples";
    EXPECT_GE(corners, 4);
    EXPECT_EQ(corners_off, 0) << "of " << corners << " corners";
    EXPECT_NEAR(area / (t.w * t.h), 1, kTiles);
    std::printf("[ polyfem  ] %-18s %-5s %7.1f x %-7.1f %d border samples within %.1e px, area %.12f × target\n",
                label().c_str(), a.name, t.w, t.h, on_border, off_side, area / (t.w * t.h));
  }
}

// Per cell: its mean saliency (the map the energy weighs, at its level-2 samples) and its shape
// residual, the similarity-fit residual of its level-2 samples.
TEST_P(PolyfemProperty, SalientCellsKeepTheirShapeBetter) {
  Subject& s = tested();
  const PolyfemModel& m = s.model();
  const warp::ScalarMap saliency{s.map.width, s.map.height, m.mesh.width, m.mesh.height, s.map.values};
  Samplings cells(m, kShapeLevel);
  const int n = int(m.mesh.cells.size());
  std::vector<double> mean_saliency(n, 0);
  for (int c = 0; c < n; ++c) {
    for (const Point& p : cells[c].source) mean_saliency[c] += saliency.at(p);
    mean_saliency[c] /= cells[c].source.size();
  }
  std::vector<int> by_saliency(n);
  std::iota(by_saliency.begin(), by_saliency.end(), 0);
  std::sort(by_saliency.begin(), by_saliency.end(), [&](int a, int b) { return mean_saliency[a] > mean_saliency[b]; });
  const int top = (n + 9) / 10, bottom = n / 2;
  for (const Aspect& a : kAspects) {
    const Target t = equal_area(s, a.ratio);
    if (t.w == s.width && t.h == s.height) continue;  // the identity: every residual 0
    const auto [emitted, warped] = s.retargeter->warped_samples(t.w, t.h, kShapeLevel);
    std::vector<double> residual(n, 0);
    for (const CellRun& run : cell_runs(s, cells, emitted)) {
      const std::vector<Point> from(emitted.vertices.begin() + run.first_vertex,
                                    emitted.vertices.begin() + run.first_vertex + cells[run.cell].source.size());
      const std::vector<Point> to(warped.begin() + run.first_vertex, warped.begin() + run.first_vertex + from.size());
      residual[run.cell] = warp::similarity_fit_residual(from, to);
    }
    double salient = 0, plain = 0;
    for (int i = 0; i < top; ++i) salient += residual[by_saliency[i]] / top;
    for (int i = n - bottom; i < n; ++i) plain += residual[by_saliency[i]] / bottom;
    EXPECT_LT(salient, plain) << a.name << ": top " << top << " cells by saliency vs bottom " << bottom;
    std::printf("[ polyfem  ] %-18s %-5s shape residual: top 10%% salient cells %.4f, bottom 50%% %.4f (ratio %.2f)\n",
                label().c_str(), a.name, salient, plain, salient / plain);
  }
}

// Whether the axpy for a target of the image's area folds a triangle of the check levels: what
// the retargeter must answer with its fallback even inside the fold-free range.
bool axpy_folds_a_check_level(const Subject& s, double tw, double th) {
  const PolyfemModel& m = s.model();
  const double aw = m.mesh.width, ah = m.mesh.height;
  const double dw = tw * aw / s.width - aw, dh = th * ah / s.height - ah;
  std::vector<Point> d(m.solution.g_x.size());
  for (std::size_t k = 0; k < d.size(); ++k) d[k] = {dw * m.solution.g_x[k], dh * m.solution.g_y[k]};
  for (int level : PolyfemRetargeting::kCheckLevels)
    for (int c = 0; c < int(m.mesh.cells.size()); ++c)
      if (warp::polyfem_cell_folds(warp::sample_polyfem_cell(m.mesh, m.solution.nodes, c, level), d)) return true;
  return false;
}

// The identity bit for bit at the image's own aspect; inside the fold-free range the fallback runs
// exactly where the axpy turns a check level's triangle over (near the range's ends: the
// quadrature points keep det J > 0, a chord triangle may still turn).
TEST_P(PolyfemProperty, IdentityAtTheImagesOwnAspectAndTheFallbackOnlyWhereTheAxpyFolds) {
  const Subject& s = tested();
  PolyfemRetargeting fresh(s.width, s.height, s.model());
  for (int level : {0, 2, 3}) {
    const auto [emitted, warped] = fresh.warped_samples(s.width, s.height, level);
    int moved = 0;
    for (std::size_t i = 0; i < warped.size(); ++i)
      moved += emitted.vertices[i].x != warped[i].x || emitted.vertices[i].y != warped[i].y;
    EXPECT_EQ(moved, 0) << "of " << warped.size() << " samples at level " << level;
  }
  int inside = 0, folding = 0;
  for (const Aspect& a : kAspects) {
    const Target t = equal_area(s, a.ratio);
    if (!s.model().fold_free.contains(t.w / s.width)) continue;
    ++inside, folding += axpy_folds_a_check_level(s, t.w, t.h);
    fresh.warped_samples(t.w, t.h, kShapeLevel);
  }
  for (const Screen& screen : kScreens) {
    const warp::ZoomGeometry g = warp::zoom_geometry(s.width, s.height, screen.w, screen.h, 0);
    if (!s.model().fold_free.contains(g.target_width / s.width)) continue;
    ++inside, folding += axpy_folds_a_check_level(s, g.target_width, g.target_height);
    for (double zoom : kZooms) fresh.view(request(screen, zoom, {s.width / 3, s.height / 3}));
  }
  EXPECT_EQ(fresh.fallback_runs(), folding) << inside << " aspects inside the fold-free range";
  std::printf("[ polyfem  ] %-18s %d of %zu aspects and screens inside the fold-free range, %d fallbacks\n",
              label().c_str(), inside, std::size(kAspects) + std::size(kScreens), folding);
}

// Near the ends of the fold-free range the axpy keeps det J > 0 at the quadrature points but may
// turn a chord triangle over (boats, astronaut, the panorama and the interior with the default
// map do): no triangle of the whole image at the check levels 2–3 folds anyway. Levels 0–1 are
// not guarded: since the line term (issue 30) one level-0 fan triangle of boats/default turns at
// W'/W = 0.52; a view never emits a level on which a visible cell folds (NoTriangleFolds), and
// their folds are printed here.
TEST_P(PolyfemProperty, NoFoldsNearTheEndsOfTheFoldFreeRange) {
  Subject& s = tested();
  const warp::AspectRange range = s.model().fold_free;
  const double high = std::min(range.high, 3.0);
  int coarse_folds = 0;
  for (double f : {0.015, 0.03, 0.05, 0.85, 0.9, 0.95, 0.98}) {
    const double scale = range.low + f * (high - range.low);  // W' = W·scale, H' = H/scale
    for (int level : {0, 1, 2, 3}) {
      const auto [mesh, warped] = s.retargeter->warped_samples(s.width * scale, s.height / scale, level);
      if (level < PolyfemRetargeting::kCheckLevels[0]) coarse_folds += fold_overs(mesh, warped);
      else EXPECT_EQ(fold_overs(mesh, warped), 0) << "W'/W " << scale << " level " << level;
    }
  }
  std::printf("[ polyfem  ] %-18s near the range's ends: %d triangles of levels 0–1 fold (not emitted)\n",
              label().c_str(), coarse_folds);
}

// The chord error of one view: every emitted edge's screen midpoint against the deformation at its
// source midpoint (polyfem_point_weights on its cell, the view's displacements), taken to the
// screen by the view's uniform zoom (warped px × screen_scale + an offset).
double measured_chord_error(const Subject& s, const View& v, int level) {
  const PolyfemModel& m = s.model();
  const double scale = v.geometry.screen_scale;
  const Point offset{v.screen[0].x - v.warped[0].x * scale, v.screen[0].y - v.warped[0].y * scale};
  const Point& last = v.warped.back();
  EXPECT_NEAR(last.x * scale + offset.x, v.screen.back().x, 1e-6);
  EXPECT_NEAR(last.y * scale + offset.y, v.screen.back().y, 1e-6);
  const auto target = s.retargeter->target(v.geometry.target_width, v.geometry.target_height);
  const std::vector<Point>& d = target->displacement;
  Samplings cells(m, level);
  std::vector<int> node;
  std::vector<double> weight;
  double worst = 0;
  for (const CellRun& run : cell_runs(s, cells, v.source)) {
    const CellSampling& cell = cells[run.cell];
    for (const warp::Triangle& t : cell.triangles)
      for (int k = 0; k < 3; ++k) {
        const int a = t[k], b = t[(k + 1) % 3];
        const Point mid{(cell.source[a].x + cell.source[b].x) / 2, (cell.source[a].y + cell.source[b].y) / 2};
        node.clear(), weight.clear();
        warp::polyfem_point_weights(m.mesh, m.solution.nodes, run.cell, mid, node, weight);
        Point f = mid;
        for (std::size_t j = 0; j < node.size(); ++j) f = {f.x + weight[j] * d[node[j]].x, f.y + weight[j] * d[node[j]].y};
        const Point on_screen{f.x * s.width / m.mesh.width, f.y * s.height / m.mesh.height};  // warped image px
        const Point &pa = v.screen[run.first_vertex + a], &pb = v.screen[run.first_vertex + b];
        worst = std::max(worst, std::hypot((pa.x + pb.x) / 2 - (on_screen.x * scale + offset.x),
                                           (pa.y + pb.y) / 2 - (on_screen.y * scale + offset.y)));
      }
  }
  return worst;
}

// Every view of `screens` × kZooms × two centres whose target the fallback made (`fallback`) or
// the axpy, its measured chord error expected within `bound` of its stats; figures printed. At
// least one view must be of the kind asked for, or nothing was checked.
template <typename Bound>
void expect_chord_errors(Subject& s, const std::string& label, bool fallback, Bound bound,
                         const std::vector<Screen>& screens) {
  const Point centres[] = {{s.width / 2, s.height / 2}, {0.3 * s.width, 0.7 * s.height}};
  std::map<int, double> worst_ratio;  // measured / reported, per level
  double worst = 0;
  int views = 0, limited = 0;
  for (const Screen& screen : screens)
    for (double zoom : kZooms)
      for (const Point& centre : centres) {
        if (zoom == 0 && &centre != &centres[0]) continue;  // the whole image, wherever the centre
        PolyfemViewStats stats;
        const View v = s.retargeter->view(request(screen, zoom, centre), &stats);
        if (stats.fallback != fallback) continue;
        const double error = measured_chord_error(s, v, stats.level);
        ++views, limited += stats.budget_limited || stats.fold_limited;
        worst = std::max(worst, error);
        if (stats.chord_error_px > 0.01) worst_ratio[stats.level] = std::max(worst_ratio[stats.level], error / stats.chord_error_px);
        EXPECT_LE(error, bound(stats) * (1 + 1e-6) + kChordSlack)
            << screen.w << "x" << screen.h << " z " << zoom << " centre (" << centre.x << ", " << centre.y
            << "): level " << stats.level << ", reported " << stats.chord_error_px << " px, " << stats.triangles
            << " triangles" << (stats.budget_limited ? ", budget-limited" : "");
      }
  EXPECT_GT(views, 0) << "no " << (fallback ? "fallback" : "axpy") << " view: nothing checked";
  std::string ratios;
  for (const auto& [level, ratio] : worst_ratio) ratios += " level " + std::to_string(level) + ": " + std::to_string(ratio).substr(0, 4);
  std::printf("[ polyfem  ] %-18s chord error of %2d %s views (%d limited): worst %.3f px; worst measured / "
              "reported%s\n",
              label.c_str(), views, fallback ? "fallback" : "axpy", limited, worst, ratios.c_str());
}

// Within 0.5 px, or within the reported bound where the level was capped (the triangle budget;
// for a fallback target also the folds of its displacement on finer levels).
double chord_bound(const PolyfemViewStats& stats) {
  const bool limited = stats.budget_limited || stats.fold_limited;
  if (!limited) {
    EXPECT_LE(stats.chord_error_px, PolyfemRetargeting::kMaxChordErrorPx);
  }
  return limited ? stats.chord_error_px : PolyfemRetargeting::kMaxChordErrorPx;
}

TEST_P(PolyfemProperty, ChordErrorAsTheClientSeesIt) {
  expect_chord_errors(tested(), label(), false, chord_bound, {std::begin(kScreens), std::end(kScreens)});
}

// A fallback target's chord error is measured on its own displacement (polyfem_retargeter.h).
// kScreens' extreme ones fall back on most models; so that every model is checked, one more
// screen whose aspect lies outside its fold-free range (where the retargeter falls back at once).
TEST_P(PolyfemProperty, ChordErrorOfFallbackViewsAsTheClientSeesIt) {
  Subject& s = tested();
  std::vector<Screen> screens(std::begin(kScreens), std::end(kScreens));
  // A view's target is W·f × H/f for a screen of aspect r = f²·W/H.
  const warp::AspectRange& range = s.model().fold_free;
  const double f = range.low > 0.05 ? 0.9 * range.low : 1.1 * range.high;
  ASSERT_LT(f, warp::AspectRange::kUnboundedAspect) << "no aspect folds the axpy";
  const double r = f * f * s.width / s.height;
  screens.push_back(r < 1 ? Screen{int(std::lround(1000 * r)), 1000} : Screen{1000, int(std::lround(1000 / r))});
  ASSERT_GT(std::min(screens.back().w, screens.back().h), 0);
  expect_chord_errors(s, label(), true, chord_bound, screens);
}

// Issue 30: what should stay straight does. Every detected line (the samples have no curator
// lines; the precomputation reads both through method_lines.h) sampled every source pixel, its
// samples that land on screen mapped through the emitted triangles; a line whose shown chord is at
// least kLongLinePx long lies within kMaxBendPx of that chord — on a phone both ways up, at zoom
// 0, centred, as the issue measures. And the warp does not buy that by turning content: the
// rotation of the triangles' affine maps (the closest rotation's angle), area-weighted over every
// on-screen triangle, has its 95th percentile within kMaxRotationDeg (the issue asks it of the
// salient tenth; all of them is stricter).
constexpr double kLongLinePx = 8, kMaxBendPx = 2, kMaxRotationDeg = 10;

struct LineFigures {
  int lines = 0;            // long enough to count
  double worst_bend = 0;    // screen px
  double rotation_p95 = 0;  // degrees
};

LineFigures line_figures(const View& v, const std::vector<warp::Segment>& lines, const Screen& screen) {
  LineFigures out;
  const warp::TriangleLocator locator(v.source);
  const auto on_screen = [&](const Point& q) { return q.x >= 0 && q.y >= 0 && q.x <= screen.w && q.y <= screen.h; };
  for (const warp::Segment& l : lines) {
    const int n = std::clamp(int(std::ceil(std::hypot(l.b.x - l.a.x, l.b.y - l.a.y))), 2, 4096);
    std::vector<Point> shown;
    for (int i = 0; i <= n; ++i) {
      const Point p{l.a.x + (l.b.x - l.a.x) * i / n, l.a.y + (l.b.y - l.a.y) * i / n};
      const warp::MeshPoint where = locator.find(p);
      if (where.triangle < 0) continue;
      const Point q = warp::locate(v.source, v.screen, p, where);
      if (on_screen(q)) shown.push_back(q);
    }
    if (shown.size() < 2 || std::hypot(shown.back().x - shown.front().x, shown.back().y - shown.front().y) < kLongLinePx)
      continue;
    ++out.lines;
    out.worst_bend = std::max(out.worst_bend, warp::chord_deviation(shown));
  }
  std::vector<std::pair<double, double>> angle_area;
  double total = 0;
  for (const warp::Triangle& t : v.source.triangles) {
    const Point &a = v.source.vertices[t[0]], &b = v.source.vertices[t[1]], &c = v.source.vertices[t[2]];
    const Point &a2 = v.screen[t[0]], &b2 = v.screen[t[1]], &c2 = v.screen[t[2]];
    const double area = std::abs(warp::signed_area2(a2, b2, c2)) / 2;
    if (!on_screen(a2) && !on_screen(b2) && !on_screen(c2)) continue;
    // M·[b − a, c − a] = [b' − a', c' − a']; the closest rotation's angle is atan2(m21 − m12, m11 + m22).
    const double e11 = b.x - a.x, e12 = c.x - a.x, e21 = b.y - a.y, e22 = c.y - a.y;
    const double f11 = b2.x - a2.x, f12 = c2.x - a2.x, f21 = b2.y - a2.y, f22 = c2.y - a2.y;
    const double det = e11 * e22 - e12 * e21;
    const double m11 = (f11 * e22 - f12 * e21) / det, m12 = (f12 * e11 - f11 * e12) / det;
    const double m21 = (f21 * e22 - f22 * e21) / det, m22 = (f22 * e11 - f21 * e12) / det;
    angle_area.push_back({std::abs(std::atan2(m21 - m12, m11 + m22)) * 180 / M_PI, area});
    total += area;
  }
  std::sort(angle_area.begin(), angle_area.end());
  double sum = 0;
  for (const auto& [angle, area] : angle_area)
    if ((sum += area) >= 0.95 * total) {
      out.rotation_p95 = angle;
      break;
    }
  return out;
}

TEST_P(PolyfemProperty, DetectedLinesStayStraightOnPhoneScreens) {
  Subject& s = tested();
  for (const Screen& screen : {Screen{360, 640}, Screen{640, 360}}) {
    PolyfemViewStats stats;
    const View v = s.retargeter->view(request(screen, 0, {s.width / 2, s.height / 2}), &stats);
    const LineFigures f = line_figures(v, s.image->detected, screen);
    EXPECT_LE(f.worst_bend, kMaxBendPx) << screen.w << "x" << screen.h << (stats.fallback ? " (fallback)" : "");
    EXPECT_LE(f.rotation_p95, kMaxRotationDeg) << screen.w << "x" << screen.h;
    std::printf("[ polyfem  ] %-18s %dx%d: %2d lines ≥ %.0f px, worst bend %.2f px, rotation p95 %.1f°%s\n",
                label().c_str(), screen.w, screen.h, f.lines, kLongLinePx, f.worst_bend, f.rotation_p95,
                stats.fallback ? " (fallback)" : "");
  }
}

INSTANTIATE_TEST_SUITE_P(PolyfemPropertySamples, PolyfemProperty,
                         ::testing::ValuesIn(testing::sample_cases({"boats_lake_sunset.jpg", "astronaut_portrait.png",
                                                                    "interior_wine_djembe_tall.jpg",
                                                                    "pano_grossmugl_field_4to1.png"})),
                         testing::sample_case_name);

// E_T + E_L = d_xᵀ(K + L_x)·d_x + d_yᵀ(K + L_y)·d_y (polyfem_system.h, polyfem_lines.h), each
// matrix by its upper triangle.
double energy(const warp::PolyfemSolution& s, const std::vector<Point>& d) {
  double e = 0;
  const auto add = [&](const warp::SymmetricMatrix& k, bool x, bool y) {
    for (std::size_t i = 0; i < k.value.size(); ++i) {
      const Point &a = d[k.row[i]], &b = d[k.col[i]];
      e += (k.row[i] == k.col[i] ? 1 : 2) * k.value[i] * ((x ? a.x * b.x : 0) + (y ? a.y * b.y : 0));
    }
  };
  add(s.stiffness, true, true), add(s.line_x, true, false), add(s.line_y, false, true);
  return e;
}

int folded_cells(const std::vector<CellSampling>& check, const std::vector<Point>& d) {
  int n = 0;
  for (const CellSampling& cell : check) n += warp::polyfem_cell_folds(cell, d);
  return n;
}

// A direct call where the axpy folds: a tenth of the width, half as high again (both axes free to move).
TEST(PolyfemFallback, FromTheStretchToALowerEnergyWithoutFoldsBorderFixedDeterministic) {
  const PolyfemModel& m = subject("boats_lake_sunset.jpg", Saliency::kDefault).model();
  const double dw = -0.9 * m.mesh.width, dh = 0.5 * m.mesh.height;
  std::vector<CellSampling> check, finer;
  for (int c = 0; c < int(m.mesh.cells.size()); ++c) {
    check.push_back(warp::sample_polyfem_cell(m.mesh, m.solution.nodes, c, 2));
    finer.push_back(warp::sample_polyfem_cell(m.mesh, m.solution.nodes, c, 3));
  }
  std::vector<Point> axpy(m.solution.g_x.size());
  for (std::size_t k = 0; k < axpy.size(); ++k) axpy[k] = {dw * m.solution.g_x[k], dh * m.solution.g_y[k]};
  const int axpy_folds = folded_cells(check, axpy);
  ASSERT_GT(axpy_folds, 0) << "the axpy must fold here for the fallback to be tested";

  const warp::PolyfemFallback f = warp::polyfem_fallback(m.mesh, m.solution, check, dw, dh);
  EXPECT_EQ(folded_cells(check, f.displacement), 0);
  const double minimum = energy(m.solution, axpy);
  // The line term's entries are ~10⁵ times K's: summed in another order, 1e-9 becomes ~1e-8.
  EXPECT_NEAR(f.energy, energy(m.solution, f.displacement), 1e-8 * f.start_energy);
  EXPECT_LT(f.energy, f.start_energy);
  EXPECT_GE(f.energy, minimum * (1 - 1e-9));
  const std::vector<Point>& nodes = m.solution.nodes.positions;
  int border = 0;
  for (std::size_t k = 0; k < nodes.size(); ++k) {
    const Point &p = nodes[k], &d = f.displacement[k];
    if (p.x == 0 || p.x == m.mesh.width) {
      EXPECT_EQ(d.x, p.x == 0 ? 0 : dw) << "node " << k;
      ++border;
    }
    if (p.y == 0 || p.y == m.mesh.height) {
      EXPECT_EQ(d.y, p.y == 0 ? 0 : dh) << "node " << k;
      ++border;
    }
  }
  EXPECT_GT(border, 0);
  const warp::PolyfemFallback again = warp::polyfem_fallback(m.mesh, m.solution, check, dw, dh);
  EXPECT_EQ(again.energy, f.energy);
  int differ = 0;
  for (std::size_t k = 0; k < nodes.size(); ++k)
    differ += again.displacement[k].x != f.displacement[k].x || again.displacement[k].y != f.displacement[k].y;
  EXPECT_EQ(differ, 0);
  std::printf("[ fallback ] boats/default width × 0.1, height × 1.5: axpy folds %d of %zu cells; E_T + E_L %.6g from the stretch → %.6g "
              "(axpy's unconstrained %.6g), %d iterations, %d rollbacks, %s; cells folded at level 3 (not checked) %d\n",
              axpy_folds, check.size(), f.start_energy, f.energy, minimum, f.iterations, f.rollbacks,
              f.converged ? "converged" : "not converged", folded_cells(finer, f.displacement));
}

// Through the retargeter: a view whose target's axpy folds gets the fallback, and neither check
// level's triangles of the whole image turn over.
TEST(PolyfemFallback, AViewOnAnExtremeScreenUsesItAndNothingFolds) {
  Subject& s = subject("boats_lake_sunset.jpg", Saliency::kDefault);
  PolyfemViewStats stats;
  const View v = s.retargeter->view(request({100, 1000}, 0, {s.width / 2, s.height / 2}), &stats);
  ASSERT_TRUE(stats.fallback);
  const double tw = v.geometry.target_width, th = v.geometry.target_height;
  const auto t = s.retargeter->target(tw, th);
  ASSERT_TRUE(t->fallback);
  EXPECT_LT(t->stats.energy, t->stats.start_energy);
  for (int level : {2, 3}) {  // what the fallback must keep from turning over (polyfem_retargeter.h)
    const auto [mesh, warped] = s.retargeter->warped_samples(tw, th, level);
    EXPECT_EQ(fold_overs(mesh, warped), 0) << "level " << level;
  }
  EXPECT_EQ(fold_overs(v.source, v.warped), 0);
  std::printf("[ fallback ] boats/default on 100x1000 (target %.1f x %.1f): E_T + E_L %.6g → %.6g, %d iterations, "
              "%d rollbacks, %s, exported at level %d\n",
              tw, th, t->stats.start_energy, t->stats.energy, t->stats.iterations, t->stats.rollbacks,
              t->stats.converged ? "converged" : "not converged", stats.level);
}

}  // namespace
}  // namespace zoomwarp
