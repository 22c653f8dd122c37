#include "api/iiif.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <vector>

#include "api/errors.h"
#include "api/url.h"

namespace zoomwarp::api {

namespace {

[[noreturn]] void bad(const std::string& what) { throw ApiError(400, "invalid_iiif_request", what); }

std::vector<std::string_view> split_commas(std::string_view s) {
  std::vector<std::string_view> parts;
  while (true) {
    std::size_t c = s.find(',');
    parts.push_back(s.substr(0, c));
    if (c == std::string_view::npos) return parts;
    s.remove_prefix(c + 1);
  }
}

// §4.1 Region.
tiles::Rect plan_region(std::string_view s, int W, int H) {
  if (s == "full") return {0, 0, W, H};
  if (s == "square") {
    const int side = std::min(W, H);
    return {(W - side) / 2, (H - side) / 2, side, side};
  }
  const bool pct = s.starts_with("pct:");
  if (pct) s.remove_prefix(4);
  auto parts = split_commas(s);
  if (parts.size() != 4) bad("region must be full, square, x,y,w,h or pct:x,y,w,h");
  double v[4];
  for (int i = 0; i < 4; ++i) {
    auto d = pct ? parse_plain_decimal(parts[i]) : std::optional<double>();
    if (!pct) {
      auto n = parse_small_uint(parts[i]);
      if (n) d = *n;
    }
    if (!d) bad("region values must be non-negative numbers");
    v[i] = *d;
  }
  if (v[2] <= 0 || v[3] <= 0) bad("region width and height must be greater than zero");
  long long x, y, w, h;
  if (pct) {
    if (v[0] >= 100 || v[1] >= 100) bad("region lies outside the image");
    x = std::llround(v[0] * W / 100.0), y = std::llround(v[1] * H / 100.0);
    w = std::llround(std::min(v[2], 100.0) * W / 100.0);
    h = std::llround(std::min(v[3], 100.0) * H / 100.0);
  } else {
    x = (long long)v[0], y = (long long)v[1], w = (long long)v[2], h = (long long)v[3];
  }
  if (x >= W || y >= H) bad("region lies outside the image");
  w = std::min<long long>(w, W - x), h = std::min<long long>(h, H - y);  // clip to the image
  if (w <= 0 || h <= 0) bad("region lies outside the image");
  return {x, y, w, h};
}

// §4.2 Size.
std::pair<int, int> plan_size(std::string_view s, long long rw, long long rh, const IiifLimits& lim) {
  const bool up = s.starts_with("^");
  if (up) s.remove_prefix(1);
  const double limit_scale = std::min({double(lim.max_width) / rw, double(lim.max_height) / rh,
                                       std::sqrt(double(lim.max_area) / (double(rw) * rh))});
  double w = 0, h = 0;
  if (s == "max") {
    const double scale = up ? limit_scale : std::min(1.0, limit_scale);
    // Floor, so that the limits hold exactly.
    return {std::max(1, int(std::floor(rw * scale + 1e-9))), std::max(1, int(std::floor(rh * scale + 1e-9)))};
  }
  if (s.starts_with("pct:")) {
    auto n = parse_plain_decimal(s.substr(4));
    if (!n || *n <= 0) bad("size pct:n needs a number greater than zero");
    if (*n > 100 && !up) bad("size over 100% needs the ^ prefix");
    w = rw * *n / 100.0, h = rh * *n / 100.0;
  } else {
    const bool confined = s.starts_with("!");
    if (confined) s.remove_prefix(1);
    auto parts = split_commas(s);
    if (parts.size() != 2) bad("size must be max, w,, ,h, pct:n, w,h or !w,h");
    // -1 stands for "not given"; parse_small_uint never yields a negative number.
    const int pw = parts[0].empty() ? -1 : parse_small_uint(parts[0]).value_or(-2);
    const int ph = parts[1].empty() ? -1 : parse_small_uint(parts[1]).value_or(-2);
    if (pw == -2 || ph == -2 || (pw < 0 && ph < 0)) bad("size width and height must be whole numbers");
    if (pw == 0 || ph == 0) bad("size must be greater than zero");
    if (confined) {
      if (pw < 0 || ph < 0) bad("size !w,h needs both w and h");
      double scale = std::min(double(pw) / rw, double(ph) / rh);
      if (!up) scale = std::min(scale, 1.0);
      w = std::min<double>(std::round(rw * scale), pw), h = std::min<double>(std::round(rh * scale), ph);
    } else if (pw > 0 && ph > 0) {
      w = pw, h = ph;
    } else if (pw > 0) {
      w = pw, h = std::round(double(rh) * pw / rw);
    } else {
      h = ph, w = std::round(double(rw) * ph / rh);
    }
  }
  w = std::max(1.0, std::round(w)), h = std::max(1.0, std::round(h));
  if (!up && (w > rw || h > rh)) bad("size larger than the region needs the ^ prefix");
  if (w > lim.max_width || h > lim.max_height || w * h > double(lim.max_area))
    bad("size exceeds maxWidth, maxHeight or maxArea of this server");
  return {int(w), int(h)};
}

}  // namespace

IiifPlan plan_iiif_request(std::string_view region, std::string_view size,
                           std::string_view rotation, std::string_view quality_format,
                           int W, int H, const IiifLimits& limits) {
  IiifPlan plan;
  plan.region = plan_region(region, W, H);
  std::tie(plan.width, plan.height) = plan_size(size, plan.region.w, plan.region.h, limits);

  // §4.3 Rotation: "n" or "!n" with 0 ≤ n ≤ 360; multiples of 90 are supported.
  plan.mirror = rotation.starts_with("!");
  if (plan.mirror) rotation.remove_prefix(1);
  auto degrees = parse_plain_decimal(rotation);
  if (!degrees || *degrees > 360) bad("rotation must be a number from 0 to 360, optionally after !");
  const double turns = *degrees / 90.0;
  if (turns != std::floor(turns))
    throw ApiError(501, "not_implemented", "only rotations by multiples of 90 degrees are supported");
  plan.rotation = (int(turns) % 4) * 90;

  // §4.4 Quality and §4.5 Format.
  const std::size_t dot = quality_format.rfind('.');
  if (dot == std::string_view::npos) bad("expected {quality}.{format}");
  const std::string_view quality = quality_format.substr(0, dot), ext = quality_format.substr(dot + 1);
  if (quality == "default") plan.quality = IiifQuality::kDefault;
  else if (quality == "color") plan.quality = IiifQuality::kColor;
  else if (quality == "gray") plan.quality = IiifQuality::kGray;
  else if (quality == "bitonal") plan.quality = IiifQuality::kBitonal;
  else bad("quality must be default, color, gray or bitonal");
  auto format = tiles::format_from_extension(ext);
  if (!format || ext == "jpeg") {
    if (ext == "tif" || ext == "gif" || ext == "jp2" || ext == "pdf")
      throw ApiError(501, "not_implemented", "format " + std::string(ext) + " is not offered; use jpg, png, webp, avif or jxl");
    bad("unknown format");
  }
  plan.format = *format;
  return plan;
}

std::string iiif_info_json(const tiles::Manifest& m, const std::string& id, const std::string& base,
                           const IiifLimits& limits) {
  nlohmann::json sizes = nlohmann::json::array();
  // Whole-image sizes the pyramid holds, smallest first, from thumbnails of 64 px up to the limits.
  for (int k = m.levels - 1; k >= 0; --k) {
    const int w = m.level_width(k), h = m.level_height(k);
    if (w > limits.max_width || h > limits.max_height || (long long)w * h > limits.max_area) break;
    if (std::max(w, h) >= 64 || k == 0) sizes.push_back({{"width", w}, {"height", h}});
  }
  nlohmann::json scale_factors = nlohmann::json::array();
  for (int k = 0; k < m.levels; ++k) {
    scale_factors.push_back(1 << k);
    if (m.level_width(k) <= m.tile_size && m.level_height(k) <= m.tile_size) break;
  }
  nlohmann::json info = {
      {"@context", "http://iiif.io/api/image/3/context.json"},
      {"id", id},
      {"type", "ImageService3"},
      {"protocol", "http://iiif.io/api/image"},
      {"profile", "level2"},
      {"width", m.width},
      {"height", m.height},
      {"maxWidth", limits.max_width},
      {"maxHeight", limits.max_height},
      {"maxArea", limits.max_area},
      {"sizes", sizes},
      {"tiles", {{{"width", m.tile_size}, {"height", m.tile_size}, {"scaleFactors", scale_factors}}}},
      {"extraFormats", {"webp", "avif", "jxl"}},
      {"extraQualities", {"color", "gray", "bitonal"}},
      {"extraFeatures", {"mirroring", "sizeUpscaling"}},
      {"partOf", {{{"id", base + "/iiif/presentation/3/" + m.id + "/manifest"}, {"type", "Manifest"}}}},
      {"seeAlso",
       {{{"id", base + "/v1/images/" + m.id},
         {"type", "Dataset"},
         {"label", {{"none", {"zoomwarp image record"}}}},
         {"format", "application/json"}}}},
  };
  return info.dump(2) + "\n";
}

}  // namespace zoomwarp::api
