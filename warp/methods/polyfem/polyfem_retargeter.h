// method=polyfem [PolyFEM] as a Retargeter, from its model (polyfem_model.h):
//
//   load        the cells sampled at levels 0–3 (polyfem_export.h), once per version; deeper
//               levels per cell when a view needs them, in a bounded cache;
//   view        the z = 0 target (the screen's aspect, the image's area) as node displacements,
//               made once per target and cached: one axpy, unless the aspect is outside the
//               fold-free range or the axpy turns a triangle of the check levels (kCheckLevels)
//               over — then [PolyFEM §4.5]'s L-BFGS with per-cell rollback (polyfem_fallback.h);
//               then traditional zoom as every method does. Only the visible cells are exported,
//               at one level k for all (shared edges stay identical): the smallest whose chord
//               error max_c |(δ_c(k).x, δ_c(k).y)|·(screen px per analysis px) is at most 0.5
//               screen px — δ_c(k) measured at level k on the target's displacement (for the
//               axpy (ΔW·δ.x, ΔH·δ.y) with δ of G, stored to level 3, deeper ones measured once
//               and kept) —, no finer than kMaxExportTriangles allows, and fold-free: a check
//               level, or one on which no visible cell folds (checked when first needed, kept
//               with the target); a cap is reported in PolyfemViewStats.
//
// Thread safety: view() may run concurrently (the caches lock).
#pragma once

#include <array>
#include <atomic>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <string_view>
#include <utility>

#include "warp/meshing/polygon_mesh.h"
#include "warp/methods/polyfem/polyfem_export.h"
#include "warp/methods/polyfem/polyfem_fallback.h"
#include "warp/methods/polyfem/polyfem_model.h"
#include "warp/methods/polyfem/polyfem_system.h"
#include "warp/methods/recent_cache.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

// How a view was exported.
struct PolyfemViewStats {
  int level = 0;                 // the subdivision level of every exported cell
  double chord_error_px = 0;     // its bound, screen px
  long triangles = 0;
  int visible_cells = 0;
  bool budget_limited = false;   // chord error > 0.5 px: kMaxExportTriangles (or kMaxPolyfemLevel) capped the level
  bool fold_limited = false;     // chord error > 0.5 px: the target's displacement folds on the finer levels
  bool fallback = false;         // the target needed [PolyFEM §4.5]'s fallback
};

class PolyfemRetargeting final : public Retargeter {
 public:
  static constexpr long kMaxExportTriangles = 60000;   // METHODS §3, "Export"
  static constexpr double kMaxChordErrorPx = 0.5;
  static constexpr int kPreparedLevels = 4;            // levels 0–3 sampled at load
  // The fallback's rollback looks at these levels' triangles (a coarse triangle may turn over
  // while its four children do not); a fallback target is exported at one of them.
  static constexpr int kCheckLevels[2] = {2, 3};
  static constexpr std::size_t kDeepCacheBytes = 64u << 20;
  static constexpr std::size_t kCachedTargets = 16;

  PolyfemRetargeting(double width, double height, PolyfemModel model);
  View view(const ViewRequest& request) override;
  View view(const ViewRequest& request, PolyfemViewStats* stats);
  std::size_t memory_bytes() override;

  // The node displacements (analysis px) for a target of tw × th image pixels, and whether the
  // fallback made them; cached (kCachedTargets).
  struct Target {
    std::vector<Point> displacement;
    bool fallback = false;
    PolyfemFallback stats;  // when it did
    // Chord deviations (a fallback target's) and fold checks per (level, cell), made as views need them.
    mutable std::mutex mutex;
    mutable std::map<std::pair<int, int>, Point> chord;
    mutable std::map<std::pair<int, int>, bool> folds;
  };
  std::shared_ptr<const Target> target(double tw, double th, const StopToken* stop = nullptr);
  // The whole image sampled at `level`, warped onto tw × th image pixels: source and warped
  // positions in image pixels (tests, compare, benchmarks).
  std::pair<Mesh, std::vector<Point>> warped_samples(double tw, double th, int level, const StopToken* stop = nullptr);
  int fallback_runs() const { return fallback_runs_.load(); }
  const PolyfemModel& model() const { return model_; }

 private:
  // Cell `cell` sampled at `level` (prepared, or from the deep cache).
  std::shared_ptr<const CellSampling> sampling(int cell, int level);
  // δ_c(level) of G (stored to level 3, deeper ones measured once and kept), and of a fallback
  // target's displacement; whether that displacement folds cell `cell` at `level`.
  Point axpy_chord(int cell, int level);
  Point target_chord(const Target& target, int cell, int level);
  bool target_folds(const Target& target, int cell, int level);
  // Appends the cells' samples at `level`, warped by `target`, to source/warped (image pixels).
  void append_cells(const std::vector<int>& cells, int level, const Target& target, double tw, double th, Mesh& source,
                    std::vector<Point>& warped);

  const double width_, height_;
  const PolyfemModel model_;
  const std::vector<Point> g_field_;  // (g_x, g_y) per node, what deep δ_c of G are measured on
  std::vector<std::vector<CellSampling>> prepared_;  // [level][cell]
  std::vector<CellSampling> check_;                  // per cell, kCheckLevels' triangles
  std::mutex deep_mutex_;
  std::map<std::pair<int, int>, std::shared_ptr<const CellSampling>> deep_;  // (level, cell)
  std::size_t deep_bytes_ = 0;
  std::map<std::pair<int, int>, Point> deep_chord_;  // (level, cell): δ_c of G beyond the model's levels
  std::mutex targets_mutex_;
  RecentCache<std::pair<double, double>, std::shared_ptr<const Target>> targets_{kCachedTargets};
  std::atomic<int> fallback_runs_{0};
};

const RetargetingMethod& polyfem_method();

}  // namespace zoomwarp::warp
