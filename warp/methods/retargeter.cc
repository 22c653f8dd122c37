#include "warp/methods/retargeter.h"

#include <utility>

#include "warp/core/uniform_zoom.h"
#include "warp/render/render.h"

namespace zoomwarp::warp {

tiles::Raster Retargeter::render(const ViewRequest& request, const tiles::ImageEntry& image,
                                 tiles::PyramidReader& reader) {
  check_view_request(request);
  return render_view(view(request), request.screen_width, request.screen_height, image, reader, request.stop);
}

Geomorph Retargeter::geomorph(const ViewRequest& from, const ViewRequest& to, View* to_view) {
  View b = view(to);
  const View a = view(from);
  Geomorph g{b.source, {}, a.screen, b.screen};
  if (to_view) *to_view = std::move(b);
  return g;
}

}  // namespace zoomwarp::warp
