// One retargeting method made ready for one image version (and one saliency kind): what a
// request is answered from. Every method behaves like Retargeting+Zooming [ICAZ §6.1]
// (docs/algorithms.md "Common contract"): the whole image is mapped onto a target W'×H' with the
// screen's aspect ratio — cached per target size inside the object — and shown with traditional
// zoom (core/uniform_zoom.h): z = 0 shows all of it, z = 1 is 1:1 of the retargeted image, the
// view centre is tracked through the warp.
//
// Thread safety: every member may be called from several threads at once (implementations lock
// their caches); objects are shared by all requests for their version.
#pragma once

#include <cstddef>
#include <stdexcept>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/raster.h"
#include "warp/core/view.h"

namespace zoomwarp::warp {

// Thrown by view() of a method that removes pixels instead of moving them (seam carving): it
// has no mesh to send. api/ answers 501.
class NoMesh : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

class Retargeter {
 public:
  virtual ~Retargeter() = default;

  // Whether view() gives a mesh (false: seam carving).
  virtual bool has_mesh() const { return true; }

  // The view of `request` as a mesh. Throws std::invalid_argument for a request out of range
  // (check_view_request), Stopped when its token says so, NoMesh when has_mesh() is false.
  virtual View view(const ViewRequest& request) = 0;

  // Both views of a zoom or pan action and the geomorph between them [ICAZ §5.3]: the client
  // blends each vertex from its `from` position to its `to` position; `to`'s view is also stored
  // in `to_view` if given. By default the two views are of one mesh — a method that warps the
  // whole image once per screen size draws the same mesh in every view of that screen, only
  // zoomed — so the pair is vertex by vertex. Throws as view() does.
  virtual Geomorph geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view = nullptr);

  // The screen: by default view() texture-mapped by render/render.h. Throws as view() does, and
  // std::runtime_error when the pyramid cannot be read.
  virtual tiles::Raster render(const ViewRequest& request, const tiles::ImageEntry& image,
                               tiles::PyramidReader& reader);

  // For a method without a mesh, what its screen shows: per screen pixel centre (row-major,
  // screen_width × screen_height) the image point drawn there, NaN where nothing is (letterbox).
  // The comparison metrics measure such a method from it (compare/metrics.h). Empty for a mesh
  // method: its view() says the same. Throws as render() does.
  virtual std::vector<Point> screen_sources(const ViewRequest& request) { return {}; }

  // Bytes held (precomputation and caches), for the engines' memory budget. Asked on every
  // request, so it must never wait for a view or a solve in progress (RecentCache::bytes()).
  virtual std::size_t memory_bytes() = 0;
};

}  // namespace zoomwarp::warp
