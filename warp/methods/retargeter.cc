#include "warp/methods/retargeter.h"

#include "warp/core/uniform_zoom.h"
#include "warp/render/render.h"

namespace zoomwarp::warp {

tiles::Raster Retargeter::render(const ViewRequest& request, const tiles::ImageEntry& image,
                                 tiles::PyramidReader& reader) {
  check_view_request(request);
  return render_view(view(request), request.screen_width, request.screen_height, image, reader, request.stop);
}

}  // namespace zoomwarp::warp
