// Retargeting+Zooming as ICAZ §6.1 evaluates it: the whole image warped once to the screen's
// aspect ratio with the same shape energy as ICAZ [ICAZ §4.2–4.3], on a uniform mesh as fine as
// the adaptive mesh's finest triangles, then traditional zoom into the result (core/uniform_zoom.h).
//
// The mesh: a conforming Delaunay mesh of the image (meshing/coarse_mesh.h, the curator's lines
// as edges) whose area bound is the largest leaf of the forest's finest stored level (500 px²
// for images up to ~20 MP, the runtime threshold at 100 %), capped at kMaxVertices — the world
// map (5400×2500) gets 29 618 vertices at 500 px². Larger images get proportionally larger
// triangles: the cap keeps one solve near 0.1 s. Weights are the selected saliency map's
// per-triangle means [ICAZ §4] (saliency=gbvs works as well as the default).
//
// Per target size (one per screen aspect: the warp does not depend on the zoom) the warp starts
// from the affine stretch, which keeps every line straight and gives oblique lines their normals
// (WarpOptions::fixed_line_normals), and converges to 0.05 target px; results are kept for the
// kCachedSizes most recently used sizes. At equal aspect the target is the image itself and the
// warp is the identity, so zoom 1 is the plain crop.
//
// A view lists every triangle of the mesh that touches the screen: at zoom 0, all of them.
// render() takes one of two paths, by the view's scale s (screen px per warped px):
// - zoomed out (s ≤ the inverse map's nodes per warped px: a screen pixel spans a node, each
//   triangle only a few pixels): through the warp's cached inverse map (render/inverse_map.h),
//   built by the first such view of a warp (kMapNodes nodes, ~4 MB) — one resampling of the map,
//   one remap of one pyramid level, within a fraction of a screen pixel of render_view(view());
// - zoomed in (few, large triangles): exactly render_view(view()), straight from the mesh and the
//   cached warp (no copy of either per request).
// The view centre's triangle is found with a TriangleLocator built at load.
//
// Thread safety: view(), render() and memory_bytes() may be called concurrently; the mesh and
// factorization are read-only, the cache is under a mutex held while a missing size is solved
// (single flight; CHOLMOD's solve on the shared factor is not reentrant); a warp's inverse map is
// built once (std::call_once) outside that mutex, by the first view that needs it.
#pragma once

#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"
#include "warp/icaz/image_model.h"
#include "warp/icaz/shape_warp.h"
#include "warp/methods/recent_cache.h"
#include "warp/render/inverse_map.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

class RetargetZoom : public Retargeter {
 public:
  static constexpr int kMaxVertices = 30000;
  static constexpr int kCachedSizes = 16;
  static constexpr std::size_t kMapNodes = std::size_t(1) << 19;  // per cached warp: 4 MB of (u, v) floats

  // Builds the uniform mesh and factors its system. Throws std::invalid_argument when the
  // curator's lines cannot be meshed (as the coarsest mesh would).
  RetargetZoom(const ImageModel& model, const SignificanceMap& saliency);

  View view(const ViewRequest& request) override;
  tiles::Raster render(const ViewRequest& request, const tiles::ImageEntry& image,
                       tiles::PyramidReader& reader) override;
  std::size_t memory_bytes() override;

  // The uniform mesh (image pixels).
  const Mesh& mesh() const { return warp_.mesh(); }

 private:
  // One target size's warp, and its inverse map, built by the first view drawn through it. The
  // map's grid is fixed at construction, so bytes() is too (the cache's weigher).
  class CachedWarp {
   public:
    CachedWarp(std::vector<Point> positions, double tw, double th);
    const std::vector<Point>& positions() const { return positions_; }
    // Whether a view at `scale` may be drawn through the map (grid_serves), known before it is built.
    bool grid_serves(double scale) const { return warp::grid_serves(grid_, scale); }
    // Thread-safe: built once; a build stopped by `stop` is left to the next caller.
    const InverseMap& map(const Mesh& source, const StopToken* stop) const;
    std::size_t bytes() const { return positions_.capacity() * sizeof(Point) + grid_.bytes(); }

   private:
    const std::vector<Point> positions_;
    const double tw_, th_;
    const InverseMap grid_;  // the map's grid, without positions
    mutable std::once_flag built_;
    mutable InverseMap map_;
  };
  using Positions = std::shared_ptr<const CachedWarp>;

  // A request's warp and where its view centre lands in it: what view() and render() share.
  struct Warped {
    ZoomGeometry geometry;
    Positions warp;
    Point centre;     // warped pixels
    WarpResult stats;  // of the solve, if this request made it (positions left empty)
  };
  Warped warped_view(const ViewRequest& r);

  // The warp onto target_width × target_height, from the cache or solved now.
  Positions warped(double target_width, double target_height, WarpResult* stats, const StopToken* stop);

  const double width_, height_;
  const ShapeWarp warp_;
  const TriangleLocator locator_{warp_.mesh()};
  std::mutex mu_;  // guards the cache and warp_'s solves
  RecentCache<std::pair<long long, long long>, Positions> cache_{  // by size (1/1000 px)
      kCachedSizes, [](const Positions& p) { return p->bytes(); }};
};

// The area bound of the uniform mesh for `model`: the largest leaf among the forest's kept nodes.
double finest_stored_leaf_area(const ImageModel& model);

// The registry entry "retarget-zoom": no precomputation file (load builds the mesh and factors it).
const RetargetingMethod& retarget_zoom_method();

}  // namespace zoomwarp::warp
