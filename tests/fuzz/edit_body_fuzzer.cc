// Fuzzes the curator-edit body parsers (api/edit_body.h) with arbitrary bytes: each must return
// an edit whose every number is finite and inside the image and that is within warp/core/limits.h,
// or throw ApiError(400), or ApiError(413) for an edit over a limit.
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "api/edit_body.h"
#include "api/errors.h"
#include "warp/core/limits.h"

namespace {

namespace limits = zoomwarp::warp::limits;

void check_point(const zoomwarp::warp::Point& p) {
  if (!(p.x >= 0 && p.x <= 2560 && p.y >= 0 && p.y <= 1600)) std::abort();
}

void check_refusal(const zoomwarp::api::ApiError& e) {
  if (e.status() != 400 && e.status() != 413) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view body(reinterpret_cast<const char*>(data), size);
  try {
    const auto edit = zoomwarp::api::parse_lines_body(body, 2560, 1600);
    if (!edit.lines || edit.lines->size() > std::size_t(limits::kMaxLines)) std::abort();
    for (const auto& s : *edit.lines) check_point(s.a), check_point(s.b);
  } catch (const zoomwarp::api::ApiError& e) {
    check_refusal(e);
  }
  try {
    const auto edit = zoomwarp::api::parse_significance_body(body, 2560, 1600);
    if (edit.significance.empty() || edit.significance.size() > std::size_t(limits::kMaxRegionsPerEdit)) std::abort();
    for (const auto& region : edit.significance) {
      if (region.polygon.size() < 3 || region.polygon.size() > std::size_t(limits::kMaxPolygonPoints) ||
          !(region.weight >= 0 && region.weight <= 1))
        std::abort();
      for (const auto& p : region.polygon) check_point(p);
    }
  } catch (const zoomwarp::api::ApiError& e) {
    check_refusal(e);
  }
  return 0;
}
