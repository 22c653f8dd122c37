// Retargeting+Zooming as ICAZ §6.1 evaluates it: the whole image warped once to the screen's
// aspect ratio with the same shape energy as ICAZ [ICAZ §4.2–4.3], on a uniform mesh as fine as
// the adaptive mesh's finest triangles, then traditional zoom into the result (core/uniform_zoom.h).
//
// The mesh: a conforming Delaunay mesh of the image (meshing/coarse_mesh.h, the curator's lines
// as edges) whose area bound is the largest leaf of the forest's finest stored level (500 px²
// for images up to ~20 MP, the runtime threshold at 100 %), capped at kMaxVertices — about 5.5 MP
// at 500 px²; larger images get proportionally larger triangles. The cap bounds the first solve
// of a screen aspect, which a first view waits for (issue 28): with the rotation term and the
// fold-over guard's refactorizations, a 16 MP photograph's 23 841 vertices took 3.2 s at
// 360×640 (a first view of 4.3 s); at the cap, 9 695 vertices, 1.1 s (0.8 s). Weights are the
// selected saliency map's per-triangle means [ICAZ §4] (saliency=gbvs works as well as the default).
//
// Per target size (one per screen aspect: the warp does not depend on the zoom) the warp starts
// from the affine stretch, which keeps every line straight and gives oblique lines their normals
// (WarpOptions::fixed_line_normals), and converges to 0.05 target px; results are kept for the
// kCachedSizes most recently used sizes. At equal aspect the target is the image itself and the
// warp is the identity, so zoom 1 is the plain crop.
//
// A view lists every triangle of the mesh that touches the screen: at zoom 0, all of them.
// render() does not draw them per view: it treats the retargeted image (tw × th) as a tile
// pyramid (render/rendered_tiles.h) whose tiles are drawn once each, exactly, by render_mesh
// (the warp's triangles on a tile-sized screen at the level's scale), kept in a byte-bounded LRU
// (kTileCacheBytes, counted in memory_bytes()), and a view is the region path applied to it: the
// level at most 2× finer than the screen, its tiles assembled, one bilinear resampling at the
// view's exact scale and origin. Within a quarter of a screen pixel and ≥ 40 dB of
// render_view(view()); at zoom 1 with an integral origin, level 0's tile pixels exactly. A view
// whose level is too large to keep (RenderedTiles::keeps: its tiles would fill more than half the
// cache — a large image's finest levels) is drawn directly, exactly as render_view draws it.
// The view centre's triangle is found with a TriangleLocator built at load.
//
// Thread safety: view(), render() and memory_bytes() may be called concurrently; the mesh and
// factorization are read-only, the warp cache is under a mutex held while a missing size is
// solved (single flight; CHOLMOD's solve on the shared factor is not reentrant); tiles are drawn
// outside it, each once (single flight); memory_bytes() takes no lock.
#pragma once

#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "warp/core/triangle_locator.h"
#include "warp/core/uniform_zoom.h"
#include "warp/icaz/image_model.h"
#include "warp/icaz/shape_warp.h"
#include "warp/methods/recent_cache.h"
#include "warp/render/rendered_tiles.h"
#include "warp/methods/retargeter.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

class RetargetZoom : public Retargeter {
 public:
  static constexpr int kMaxVertices = 12000;
  static constexpr int kCachedSizes = 16;
  // WarpOptions::rotation_weight of the whole-image warp (ours, issue 30; docs/algorithms.md):
  // the corpus's worst salient rotation p95 at 360×640 from 10.6° (ρ = 0) to 8.5° (1) and 6.2°
  // (3), the gain within 3 %; the first solve of an aspect takes about twice as long. As ICAZ's
  // (Icaz::kRotationWeight), only where the lines need the joint path anyway: without lines
  // (lines=none) the energy is the paper's and the mesh that of before issue 30.
  static constexpr double kRotationWeight = 3;
  // The retargeted images' tiles kept, all sizes together: the tiles a 480×360 screen's zoom 0 … 0.5
  // read on a 20 MP image at one aspect are ~20 MB.
  static constexpr std::size_t kTileCacheBytes = std::size_t(64) << 20;

  // Builds the uniform mesh and factors its system; keeps up to `tile_cache_bytes` of tiles.
  // Throws std::invalid_argument when the curator's lines cannot be meshed (as the coarsest mesh
  // would).
  RetargetZoom(const ImageModel& model, const SignificanceMap& saliency, std::size_t tile_cache_bytes = kTileCacheBytes);

  View view(const ViewRequest& request) override;
  tiles::Raster render(const ViewRequest& request, const tiles::ImageEntry& image,
                       tiles::PyramidReader& reader) override;
  std::size_t memory_bytes() override;

  // Tile (tx, ty) of level `level` of the retargeted image at the request's screen aspect — the
  // pixels render() resamples (RenderedTiles::kTileSize² but at the right and bottom edges).
  // Throws as render() does, and std::out_of_range for a tile outside the level.
  std::shared_ptr<const tiles::Raster> tile(const ViewRequest& request, int level, int tx, int ty,
                                            const tiles::ImageEntry& image, tiles::PyramidReader& reader);

  // The uniform mesh (image pixels).
  const Mesh& mesh() const { return warp_.mesh(); }

 private:
  // One target size's warp: its vertices' positions (warped px).
  using Positions = std::shared_ptr<const std::vector<Point>>;

  // A request's warp and where its view centre lands in it: what view() and render() share.
  struct Warped {
    ZoomGeometry geometry;
    Positions warp;
    Point centre;     // warped pixels
    WarpResult stats;  // of the solve, if this request made it (positions left empty)
  };
  Warped warped_view(const ViewRequest& r);

  // The retargeted image of a request's warp as the tiles know it: the key names the image
  // version and the warp (its size), so that neither a replaced image nor another aspect shows
  // another's pixels.
  static RenderedTiles::Image retargeted(const Warped& w, const tiles::ImageEntry& image);
  RenderedTiles::DrawTile tile_drawer(const Warped& w, const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                      const StopToken* stop) const;

  // The retargeted image `warp` as `place` puts it on a w × h screen: its triangles drawn by
  // render_mesh — what render_view shows there. A tile is rectangle r of level k: scale 2^-k,
  // offset −(r.x, r.y).
  tiles::Raster draw(const std::vector<Point>& warp, const ZoomPlacement& place, int w, int h,
                     const tiles::ImageEntry& image, tiles::PyramidReader& reader, const StopToken* stop) const;

  // The warp onto target_width × target_height, from the cache or solved now.
  Positions warped(double target_width, double target_height, WarpResult* stats, const StopToken* stop);

  const double width_, height_;
  const ShapeWarp warp_;
  const TriangleLocator locator_{warp_.mesh()};
  std::mutex mu_;  // guards the cache and warp_'s solves
  RecentCache<std::pair<long long, long long>, Positions> cache_{  // by size (1/1000 px)
      kCachedSizes, [](const Positions& p) { return p->capacity() * sizeof(Point); }};
  RenderedTiles tiles_;
};

// The area bound of the uniform mesh for `model`: the largest leaf among the forest's kept nodes.
double finest_stored_leaf_area(const ImageModel& model);

// The registry entry "retarget-zoom": no precomputation file (load builds the mesh and factors it).
const RetargetingMethod& retarget_zoom_method();

}  // namespace zoomwarp::warp
