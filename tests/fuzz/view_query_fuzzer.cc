// Fuzzes the view-parameter parser (api/view_query.h) with arbitrary query strings: it must
// either return a view inside the documented ranges or throw ApiError(400) — never crash, hang,
// or let a NaN or an out-of-range number through.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "api/errors.h"
#include "api/view_query.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view query(reinterpret_cast<const char*>(data), size);
  for (auto route : {zoomwarp::api::ViewRoute::kMesh, zoomwarp::api::ViewRoute::kViewport}) {
    try {
      const auto q = zoomwarp::api::parse_view_query(query, route, 2560, 1600);
      const auto& v = q.view;
      if (!(v.zoom >= 0 && v.zoom <= 1) || !(v.cx >= 0 && v.cx <= 2560) || !(v.cy >= 0 && v.cy <= 1600) ||
          v.screen_width < 16 || v.screen_width > 4096 || v.screen_height < 16 || v.screen_height > 4096)
        std::abort();
      if (q.from && !(q.from->zoom >= 0 && q.from->zoom <= 1 && std::isfinite(q.from->cx) && std::isfinite(q.from->cy)))
        std::abort();
      (void)q.canonical();
    } catch (const zoomwarp::api::ApiError& e) {
      if (e.status() != 400) std::abort();
    }
  }
  return 0;
}
