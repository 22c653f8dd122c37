// The image management routes: /v1/images (list, upload) and /v1/images/{id} (describe, delete).
// An upload is ingested on the worker that answers it (tiles/ingest.h); the warp analyses are
// made on first use, not here (api/warp_engines.h).
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>

#include "api/description.h"
#include "api/errors.h"
#include "api/http_caching.h"
#include "api/presentation.h"
#include "api/responses.h"
#include "api/router.h"
#include "api/url.h"
#include "tiles/image_id.h"
#include "warp/analysis/derived_files.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

json image_json(const tiles::Manifest& m) {
  return {{"id", m.id},
          {"width", m.width},
          {"height", m.height},
          {"levels", m.levels},
          {"tile_size", m.tile_size},
          {"version", m.version},
          {"status", "ready"},
          {"private", m.is_private},
          {"channels", m.channels},
          {"created", http_date(m.created_ms)},
          {"source", {{"format", m.source_format}, {"bits", m.source_bits}, {"bytes", m.source_bytes}}},
          {"links",
           {{"self", "/v1/images/" + m.id},
            {"dzi", "/dzi/" + m.id + ".dzi"},
            {"iiif", "/iiif/3/" + m.id + "/info.json"},
            {"manifest", manifest_path(m.id)},
            {"metadata", "/v1/images/" + m.id + "/metadata"}}}};
}

// The default id of an upload: a digest of its bytes.
std::string content_id(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint64_t h = kFnvOffset;
  char buf[1 << 16];
  while (in.read(buf, sizeof buf) || in.gcount() > 0) h = fnv1a64(std::string_view(buf, std::size_t(in.gcount())), h);
  return "img-" + hex64(h);
}

// An upload's private=: true/1 or false/0, nothing else.
bool parse_private_flag(const std::string& v) {
  if (v == "true" || v == "1") return true;
  if (v == "false" || v == "0") return false;
  throw ApiError(400, "invalid_query", "private must be true, 1, false or 0, not '" + v + "'");
}

}  // namespace

// Private images are listed for curator keys only; such a list is for that client alone.
std::optional<Response> Router::list_images(const Request& req, const PathParams&, bool) {
  const bool curator = access_.has_curator_key(req);
  json images = json::array();
  for (const auto& entry : store_.list())
    if (curator || !entry->manifest.is_private) images.push_back(image_json(entry->manifest));
  Response r = json_response(200, {{"images", images}});
  r.route = "images_list";
  r.set_header("Cache-Control", curator ? "private, no-cache" : "no-cache");
  return r;
}

std::optional<Response> Router::describe_image(const Request& req, const PathParams& p, bool) {
  return describe(*access_.readable_image(req, param(p, "id")));
}

Response Router::describe(const tiles::ImageEntry& entry) const {
  json j = image_json(entry.manifest);
  // Which analyses the version holds (issue 28: made on first use, or by `zoomwarp analyse`).
  j["analyses"] = warp::stored_analyses(entry);
  Response r = json_response(200, j);
  r.route = "image_get";
  r.set_header("ETag", make_etag(entry.manifest.version, "image"));
  r.set_header("Cache-Control", entry.manifest.is_private ? "private, no-cache" : "no-cache");
  return r;
}

std::optional<Response> Router::delete_image(const Request&, const PathParams& p, bool) {
  const std::string& id = param(p, "id");
  check_image_id(id);
  // An image whose manifest is damaged cannot be found, but it can be removed.
  const auto entry = store_.find(id);
  if (!store_.remove(id)) throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
  if (entry) reader_.forget(*entry);
  Response r;
  r.status = 204;
  r.route = "image_delete";
  return r;
}

std::optional<Response> Router::upload_image(const Request& req, const PathParams&, bool may_compute) {
  if (!may_compute) return std::nullopt;
  auto query = parse_query(req.query);
  if (!query) throw ApiError(400, "invalid_query", "the query string is not well-formed");
  std::string id;
  tiles::IngestOptions options = config_.ingest;
  std::map<std::string, std::string> description_fields;
  for (const auto& [k, v] : *query) {
    if (k == "id") id = v;
    else if (k == "private") options.is_private = parse_private_flag(v);
    else if (k == "label" || k == "summary" || k == "rights" || k == "attribution") description_fields[k] = v;
    else
      throw ApiError(400, "invalid_query",
                     "unknown parameter '" + k + "' (id, private, label, summary, rights and attribution are accepted)");
  }
  std::error_code ec;
  if (req.body_file.empty() || std::filesystem::file_size(req.body_file, ec) == 0 || ec)
    throw ApiError(400, "empty_body", "send the image file as the request body");
  if (id.empty()) id = content_id(req.body_file);
  if (!tiles::is_valid_image_id(id))
    throw ApiError(400, "invalid_id",
                   "image ids are 1-128 characters from A-Z a-z 0-9 . _ - and start with a letter or digit");
  if (!description_fields.empty()) {
    // Laid over the description the image has when its version is published (a re-upload giving
    // a label keeps the rest, and an edit made during the ingest), in one version with the
    // pixels. Bad fields are refused before the ingest, on the description known now.
    const auto published = store_.find(id);
    description_with_upload_fields(published ? read_description(*published) : Description{}, description_fields);
    options.carry = carry_description(description_fields);
  }
  try {
    tiles::Manifest m = tiles::ingest_image(store_, req.body_file, id, options);
    Response r = json_response(201, image_json(m));
    r.route = "image_upload";
    r.set_header("Location", "/v1/images/" + m.id);
    return r;
  } catch (const tiles::IngestError& e) {
    using Kind = tiles::IngestError::Kind;
    switch (e.kind()) {
      case Kind::kUnsupportedFormat: throw ApiError(415, "unsupported_format", without_paths(e.what()), e.what());
      case Kind::kTooLarge: throw ApiError(413, "image_too_large", without_paths(e.what()), e.what());
      case Kind::kCorrupt: throw ApiError(422, "corrupt_image", without_paths(e.what()), e.what());
      case Kind::kIo: throw ApiError(500, "store_error", "the image could not be stored", e.what());
    }
    throw;
  } catch (const tiles::VersionConflict& err) {
    throw ApiError(409, "conflict",
                   std::string(err.what()) + ": the image kept changing while this upload was published; send it again");
  }
}

}  // namespace zoomwarp::api
