// IIIF Image API 3.0 (https://iiif.io/api/image/3.0/): the parameters of an image request and
// the info.json document. Pure functions of the request and the image size; the router reads and
// encodes the pixels.
#pragma once

#include <string>
#include <string_view>

#include "tiles/encode.h"
#include "tiles/manifest.h"
#include "tiles/raster.h"

namespace zoomwarp::api {

struct IiifLimits {
  int max_width = 8192;
  int max_height = 8192;
  long long max_area = 4096LL * 4096LL;
};

enum class IiifQuality { kDefault, kColor, kGray, kBitonal };

// What to produce for {region}/{size}/{rotation}/{quality}.{format}.
struct IiifPlan {
  tiles::Rect region;  // in full-resolution pixels, inside the image
  int width = 0;       // output size before rotation
  int height = 0;
  bool mirror = false;  // applied before rotation
  int rotation = 0;     // clockwise: 0, 90, 180 or 270
  IiifQuality quality = IiifQuality::kDefault;
  tiles::ImageFormat format = tiles::ImageFormat::kJpeg;
};

// Parses and resolves the four path segments against an image of image_w × image_h.
// Throws ApiError: 400 for malformed or out-of-range requests (including sizes over the limits
// and upscaling without '^'), 501 for well-formed features we do not offer (arbitrary rotation
// angles, formats other than jpg/png/webp).
IiifPlan plan_iiif_request(std::string_view region, std::string_view size,
                           std::string_view rotation, std::string_view quality_format,
                           int image_w, int image_h, const IiifLimits& limits);

// The info.json of an image; `id` is the absolute base URI of the image service, `base` the
// server's origin: `partOf` names the image's Presentation manifest (api/presentation.h) and
// `seeAlso` its /v1/images record (Image API 3.0 §5.7).
std::string iiif_info_json(const tiles::Manifest& m, const std::string& id, const std::string& base,
                           const IiifLimits& limits);

}  // namespace zoomwarp::api
