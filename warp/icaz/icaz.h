// The Interactive Content-Aware Zooming operator [ICAZ §5] with the two-level warp of [ICAZ §5.2]:
//
//   1. zoom geometry: target size and viewing area from z (zoom_curve.h);
//   2. coarse warp of the coarsest mesh to the target size (cached per target size, so panning at
//      a fixed zoom skips it), started from the warps at the two anchor aspects around the
//      target's (see coarse_start in icaz.cc), so that a zoom action needs at most one iteration
//      (mostly none);
//   3. the viewing area is centred on the view centre's place in the coarse warp, clamped inside
//      the warped image (no black bands);
//   4. the LOD cut is refined where, judged by the coarse warp, triangles touch the viewing area and
//      are larger than `max_screen_area` on screen;
//   5. fine warp of the refined mesh near the viewing area, started from the coarse result
//      (nested iteration, [ICAZ §6.2]) and pinned to it further out; the viewing area is placed again on
//      the fine result.
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <vector>

#include "warp/icaz/image_model.h"
#include "warp/icaz/lod_cut.h"
#include "warp/icaz/shape_warp.h"
#include "warp/core/stop_token.h"
#include "warp/core/view.h"
#include "warp/core/zoom_curve.h"
#include "warp/window/view_window.h"

namespace zoomwarp::warp {

struct IcazOptions {
  // The fine level is solved for the triangles within this fraction of the viewing area's larger
  // side around it (and along line constraints), with the coarse result pinned beyond. 0.25 keeps
  // visible vertices within ~1.3 screen px of solving the whole refined mesh (0.1: 2 px, 0.5:
  // 0.6 px; world map, 480×360) at a third of the cost; infinity solves it all.
  double solve_margin = 0.25;
  // Nodes made lazily beyond the stored forest are forgotten once the forest grows past this
  // (≈ 60 bytes a node), which starts a new forest epoch.
  int max_forest_nodes = 1 << 20;
  // The LOD cut is refined to at most about this many triangles on screen: a larger screen gets
  // a proportionally larger effective max_screen_area (screen pixels / this). 4096 leaves
  // screens up to 1920×1080 at the requested 500 px² and bounds a 4096×4096 view (limits.h) to
  // the cost of a full-HD one.
  int max_screen_triangles = 4096;
  // Called with the coarse-cache lock held, just before a coarse warp missing from the cache is
  // solved: lets a test hold a solve in progress (IcazMemory). Empty in the product.
  std::function<void()> before_coarse_solve;
};

// Thread-safe: every public member may be called from several threads at once. The model and the coarsest mesh's factorization are
// read-only after construction; only caches change, each under its own lock:
//  - the forest's lazy nodes and their means, and the forest epoch: a std::shared_mutex. Views and
//    geomorphs hold it shared, so views of one image run in parallel. A view
//    that needs nodes not made yet (lazy levels of a very large image, seen the first time) is
//    redone holding it exclusively — which is also when lazy nodes are forgotten past the cap;
//  - the coarse-warp cache (least recently used, 64 target sizes) and the anchor warps its
//    solves start from (64, likewise): a mutex, held while a missing entry is solved (a single
//    flight; CHOLMOD's solve on the shared factor is not reentrant).
// memory_bytes() takes neither lock: it reads byte counts kept in atomics, updated by whoever
// changes the caches while holding their lock.
class Icaz {
 public:
  explicit Icaz(ImageModel model, const IcazOptions& options = {});
  ~Icaz();

  // Views of the same image share the forest and the coarse-warp cache. Throws
  // std::invalid_argument for non-finite numbers or a screen beyond limits.h (kMaxScreenSide,
  // kMaxScreenPixels), and Stopped when the request's token says so. Zoom is clamped to [0, 1]
  // and the view centre to the image.
  View view(const ViewRequest& request);

  // Both views and the geomorph between them, within one forest epoch; the second view is also
  // stored in `to_view` if given.
  Geomorph geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view = nullptr);

  // The traditional baseline in the same interface [ICAZ §1, §6.1], on the coarsest mesh: uniform
  // scaling and cropping; the magnification goes from "whole image fits the screen"
  // (letterboxed) at z = 0 to 1:1 at z = 1, along the request's curve. (Retargeting+Zooming is a
  // registered method: methods/retarget_zoom/.)
  View traditional(const ViewRequest& request);

  // The common refinement of the cuts of `from` and `to`, both made by this object in the
  // current forest epoch (else std::invalid_argument).
  Geomorph geomorph(const View& from, const View& to, const StopToken* stop = nullptr);

  const ImageModel& model() const { return model_; }

  // Where the model's significance lies along each axis: what fit= places its window by
  // (window/view_window.h), for every method's views of this version and saliency kind.
  const SignificanceProfile& significance_profile() const { return profile_; }

  // WarpOptions::rotation_weight of every solve of a model that holds lines (ours, issue 30;
  // docs/algorithms.md, ICAZ): holding each line whole leans the salient shapes beside it (the
  // boats at 1 MP on a 9:16 screen: rotation p95 6.5° without lines, 10.05° with them). Over 24
  // photographs at 1 MP, zoom 0, on both phone screens, ρ = 1 took the worst from 10.05° to
  // 8.7°, the gain within −5 … +2 % and the anisotropy at most 2 % higher. ρ = 2 and 3 (6.9°)
  // moved the coarse warp's anchor-blend pop (a 3 px jump where the blend stops being close
  // enough, icaz.cc) onto icaz_test's zoom grid. Only where the lines need the joint path
  // anyway (an oblique line, or one held between vertices: ShapeWarp::factored_once() false), as
  // the term couples x and y: without lines (lines=none, or none detected) or with axis-aligned
  // ones on vertices, the energy stays the paper's and the fast path stays.
  static constexpr double kRotationWeight = 1;
  // The options of every solve of a model whose coarsest mesh's warp is `coarse` (the coarse warp,
  // its anchors, the fine level) but the tolerance: line normals fixed (tolerance_for in icaz.cc
  // says why) and kRotationWeight where its lines need the joint path.
  static WarpOptions solve_options(const ShapeWarp& coarse, const StopToken* stop);

  // Bytes held: the model, the forest with its lazy nodes, node means, cached coarse and anchor
  // warps. Asked on every request (the engines' memory budget, /metrics), so it never waits for a
  // view or a coarse solve in progress: it takes no lock (the Retargeter contract,
  // warp/methods/retargeter.h). Counts as of the last completed change to a cache.
  std::size_t memory_bytes() const noexcept;

 private:
  struct CachedWarp {
    std::vector<Point> positions;
    std::uint64_t last_used = 0;
    bool guarded = false;  // the fold-over guard reweighted it (anchors only)
    std::array<double, 3> gap{};  // anchor_gap at each level (NaN until measured; anchors only)
  };
  struct CoarseWarp;  // a coarse warp with each coarsest triangle's affine map (icaz.cc)
  struct CachedCoarse {
    std::shared_ptr<const CoarseWarp> warp;
    std::uint64_t last_used = 0;
  };

  WarpOptions tolerance_for(const ZoomGeometry& g, const StopToken* stop) const;
  std::shared_ptr<const CoarseWarp> coarse_warp(const ZoomGeometry& g, WarpResult* stats, const StopToken* stop);
  // The coarse warp's start for a target size (empty: the affine stretch) and whether it is
  // within `tolerance` of the answer as it is; the anchor warps it is made of, blended at u
  // finest-grid steps from the image's aspect between anchors `stride` steps apart; how far one
  // iteration moves their blend midway between anchor j and the next one of a level (all with
  // coarse_mu_ held). Anchor j is the image's aspect × e^(j · kFinestAnchorStep) at the image's
  // area; level 0 uses every fourth, level 1 every second, level 2 each.
  static constexpr int kAnchorLevels = 2;
  static constexpr double kAnchorStep = 0.05;  // log aspect, level 0
  static constexpr double kFinestAnchorStep = kAnchorStep / (1 << kAnchorLevels);
  static constexpr double kAnchorTolerance = 0.01;  // target px
  std::vector<Point> coarse_start(double target_width, double target_height, double tolerance, const StopToken* stop,
                                  bool* close_enough);
  std::vector<Point> anchor_blend(double u, int stride, double target_width, double target_height, const StopToken* stop);
  double anchor_gap(int j, int level, const StopToken* stop);
  const CachedWarp& anchor(int j, const StopToken* stop);
  double anchor_width(int j) const;
  double anchor_height(int j) const;
  // `grow`: the caller holds forest_mu_ exclusively and the forest and node means may grow;
  // otherwise it holds it shared and a missing node or mean throws ForestGrowthNeeded.
  double node_mean(int node, bool grow);
  double node_weight(int node, bool grow);
  View view_in(const ViewRequest& request, bool grow);
  Geomorph geomorph_in(const View& from, const View& to, const StopToken* stop, bool grow);
  template <class Work>
  auto with_forest(Work work);
  // Recount forest_bytes_ (caller holds forest_mu_ exclusively) and coarse_bytes_ (coarse_mu_).
  void count_forest_bytes();
  void count_coarse_bytes();

  const ImageModel model_;
  const SignificanceProfile profile_;
  const IcazOptions options_;
  const ShapeWarp coarse_;
  double sig_lo_ = 0, sig_hi_ = 1;  // range of root means: maps significance to [w_min, 1]
  std::size_t model_bytes_ = 0;     // the model's arrays, fixed after construction
  std::atomic<std::size_t> forest_bytes_{0};  // forest_ and node_mean_, as of the last change
  std::atomic<std::size_t> coarse_bytes_{0};  // coarse_cache_ and anchors_, as of the last change

  std::shared_mutex forest_mu_;  // guards the four members below
  Forest forest_;
  int forest_epoch_ = 0;
  LodCut root_cut_;  // the coarsest mesh as a cut: every view's refinement starts from a copy
  std::vector<double> node_mean_;  // per forest node, NaN until computed

  std::mutex coarse_mu_;  // guards the two caches below and coarse_'s solves
  std::map<std::pair<long long, long long>, CachedCoarse> coarse_cache_;  // by target size (1/1000 px)
  std::map<int, CachedWarp> anchors_;  // coarse warps at the anchor aspects, by grid index
  std::uint64_t coarse_clock_ = 0;
};

}  // namespace zoomwarp::warp
