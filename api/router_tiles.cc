// The tile conventions existing viewers speak: Deep Zoom (/dzi/{id}.dzi and its tiles) and the
// IIIF Image API 3.0 (/iiif/3/{id}: base, info.json, image requests). A request that is exactly
// one stored JPEG tile is answered with its bytes (api/stored_tile_match.h); every other is read,
// resampled and encoded. All go through the response cache (api/cached_responses.h).
#include "api/errors.h"
#include "api/responses.h"
#include "api/router.h"
#include "api/url.h"
#include "tiles/raster_ops.h"

namespace zoomwarp::api {

namespace {

tiles::Raster apply_quality(tiles::Raster r, IiifQuality q) {
  switch (q) {
    case IiifQuality::kGray: return tiles::to_grey(r);
    case IiifQuality::kBitonal: return tiles::to_bitonal(r);
    default: return r;
  }
}

}  // namespace

std::optional<Response> Router::dzi_descriptor_route(const Request& req, const PathParams& p, bool) {
  return responses_.image_response(req, *access_.readable_image(req, param(p, "id")), "dzi_descriptor", "", true,
                        [&](const tiles::ImageEntry& e) {
                          return body_response("application/xml", dzi_descriptor(e.manifest, config_.dzi,
                                                                                 e.manifest.has_alpha() ? "png" : "jpg"));
                        });
}

std::optional<Response> Router::dzi_tile_route(const Request& req, const PathParams& p, bool may_compute) {
  auto level = parse_small_uint(param(p, "level"));
  auto name = parse_dzi_tile_name(param(p, "tile"));
  if (!level || !name)
    throw ApiError(400, "invalid_tile", "tile paths are /dzi/{id}_files/{level}/{col}_{row}.{jpg|png|webp}");
  auto format = tiles::format_from_extension(name->extension);
  if (!format) throw ApiError(400, "invalid_format", "tile format must be jpg, png, webp, avif or jxl");
  auto entry = access_.readable_image(req, param(p, "id"));
  auto tile = dzi_tile(entry->manifest, config_.dzi, *level, name->col, name->row);
  if (!tile)
    throw ApiError(404, "tile_not_found",
                   "no tile " + std::to_string(name->col) + "_" + std::to_string(name->row) + " at level " +
                       std::to_string(*level) + " (levels 0-" + std::to_string(entry->manifest.levels - 1) + ")");
  return responses_.image_response(req, *entry, "dzi_tile", "", may_compute, [&](const tiles::ImageEntry& e) {
    if (auto stored = dzi_stored_tile(e.manifest, config_.dzi, *tile, *format)) return stored_tile_response(e, *stored);
    tiles::Raster pixels = reader_.read_level(e, tile->store_level, tile->rect);
    return body_response(std::string(tiles::mime_type(*format)), tiles::encode_image(pixels, *format, config_.encode));
  });
}

// IIIF base URI: redirect to the image information (§2.1).
std::optional<Response> Router::iiif_base(const Request& req, const PathParams& p, bool) {
  access_.readable_service(req, param(p, "id"));
  Response r;
  r.status = 303;
  r.route = "iiif_base";
  r.set_header("Location", req.path + "/info.json");
  return r;
}

std::optional<Response> Router::iiif_info(const Request& req, const PathParams& p, bool) {
  const std::string base = base_url(req);
  const bool ld = req.accept.find("application/ld+json") != std::string::npos;
  // The service's id is the segment asked for: a private manifest's service token stays in it, so
  // the viewer's tile requests carry it too.
  const std::string& segment = param(p, "id");
  return responses_.image_response(req, *access_.readable_service(req, segment), "iiif_info", base + (ld ? "|ld" : ""), true,
                        [&](const tiles::ImageEntry& e) {
                          Response r = body_response(
                              ld ? "application/ld+json;profile=\"http://iiif.io/api/image/3/context.json\""
                                 : "application/json",
                              iiif_info_json(e.manifest, base + "/iiif/3/" + segment, base, config_.iiif));
                          r.set_header("Link", "<http://iiif.io/api/image/3/level2.json>;rel=\"profile\"");
                          return r;
                        });
}

std::optional<Response> Router::iiif_image(const Request& req, const PathParams& p, bool may_compute) {
  auto entry = access_.readable_service(req, param(p, "id"));
  const IiifPlan plan =
      plan_iiif_request(param(p, "region"), param(p, "size"), param(p, "rotation"),
                        param(p, "quality") + "." + param(p, "format"), entry->manifest.width, entry->manifest.height,
                        config_.iiif);
  return responses_.image_response(req, *entry, "iiif_image", "", may_compute, [&](const tiles::ImageEntry& e) {
    const auto stored = iiif_stored_tile(e.manifest, plan);
    Response r = stored ? stored_tile_response(e, *stored) : encoded_iiif_response(e, plan);
    r.set_header("Link", "<http://iiif.io/api/image/3/level2.json>;rel=\"profile\"");
    return r;
  });
}

Response Router::encoded_iiif_response(const tiles::ImageEntry& entry, const IiifPlan& plan) {
  tiles::Raster pixels = reader_.read_scaled(entry, plan.region, plan.width, plan.height);
  if (plan.mirror) pixels = tiles::mirror_horizontally(pixels);
  pixels = tiles::rotate_clockwise(pixels, plan.rotation);
  pixels = apply_quality(std::move(pixels), plan.quality);
  std::string body;
  try {
    body = tiles::encode_image(pixels, plan.format, config_.encode);
  } catch (const std::invalid_argument& err) {
    throw ApiError(400, "invalid_iiif_request", err.what());
  }
  return body_response(std::string(tiles::mime_type(plan.format)), std::move(body));
}

Response Router::stored_tile_response(const tiles::ImageEntry& entry, const StoredTileRef& tile) {
  Response r = body_response(std::string(tiles::mime_type(tiles::ImageFormat::kJpeg)),
                             stored_tiles_.jpeg_tile(entry, tile.level, tile.tx, tile.ty));
  passed_through_.fetch_add(1, std::memory_order_relaxed);
  return r;
}

}  // namespace zoomwarp::api
