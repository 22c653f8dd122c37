// The curator's description (/v1/images/{id}/metadata) and the IIIF Presentation 3.0 documents
// made from it (api/presentation.h): a manifest per image, a paged collection of the public ones.
#include <charconv>
#include <chrono>

#include "api/description.h"
#include "api/errors.h"
#include "api/http_caching.h"
#include "api/presentation.h"
#include "api/responses.h"
#include "api/router.h"
#include "api/url.h"

namespace zoomwarp::api {

namespace {

// How long the service token in a private image's manifest lasts when the manifest was read with
// a curator key (through a signed URL, the token ends with the URL).
constexpr std::int64_t kServiceTokenSeconds = 3600;

std::string presentation_type(const Request& req) {
  return req.accept.find("application/ld+json") != std::string::npos
             ? "application/ld+json;profile=\"http://iiif.io/api/presentation/3/context.json\""
             : "application/json";
}

std::int64_t unix_now() {
  return std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch()).count();
}

// The `expires` of a signed URL's query, or nullopt.
std::optional<std::int64_t> signed_expiry(std::string_view query) {
  const auto pairs = parse_query(query);
  if (!pairs) return std::nullopt;
  for (const auto& [name, value] : *pairs)
    if (name == "expires") {
      std::int64_t v = 0;
      const auto [end, ec] = std::from_chars(value.data(), value.data() + value.size(), v);
      if (ec == std::errc() && end == value.data() + value.size()) return v;
    }
  return std::nullopt;
}

Response description_response(const tiles::ImageEntry& entry, const Description& d, const std::string& route) {
  Response r = body_response("application/json", description_json(d));
  r.route = route;
  // The image's ETag, which PUT's If-Match compares with (as the edits').
  r.set_header("ETag", make_etag(entry.manifest.version, "image"));
  r.set_header("Cache-Control", entry.manifest.is_private ? "private, no-cache" : "no-cache");
  return r;
}

}  // namespace

std::optional<Response> Router::get_metadata(const Request& req, const PathParams& p, bool may_compute) {
  auto entry = access_.readable_image(req, param(p, "id"));
  if (!may_compute) return std::nullopt;  // reads the version's description.json: on a worker
  return description_response(*entry, read_description(*entry), "metadata_get");
}

std::optional<Response> Router::put_metadata(const Request& req, const PathParams& p, bool may_compute) {
  if (!may_compute) return std::nullopt;
  auto entry = find_image(store_, param(p, "id"));
  const std::string image_etag = make_etag(entry->manifest.version, "image");
  if (!req.if_match.empty() && !if_match_matches(req.if_match, image_etag))
    throw ApiError(412, "precondition_failed", "the image changed: its ETag is now " + image_etag);
  const Description d = parse_description(req.body);
  try {
    entry = publish_description(store_, *entry, d);
  } catch (const tiles::VersionConflict& err) {
    throw ApiError(409, "conflict", std::string(err.what()) + "; read the image again and retry");
  }
  return description_response(*entry, d, "metadata_put");
}

std::optional<Response> Router::iiif_manifest(const Request& req, const PathParams& p, bool may_compute) {
  const std::string& id = param(p, "id");
  auto entry = access_.readable_image(req, id);
  const std::string base = base_url(req);
  ManifestLinks links{base, base + "/iiif/3/" + id, !entry->manifest.is_private};
  if (!entry->manifest.is_private)
    return responses_.image_response(req, *entry, "iiif_manifest", base + "|" + presentation_type(req), may_compute,
                          [&](const tiles::ImageEntry& e) {
                            return body_response(presentation_type(req),
                                                 manifest_json(e.manifest, read_description(e), links, config_.iiif));
                          });
  if (!may_compute) return std::nullopt;
  // A private image's manifest, for a curator key or a signed URL: its service is signed as a
  // whole (api/url_signing.h service token), so that a viewer holding only this manifest can load
  // the tiles; until the signed URL expires, or for kServiceTokenSeconds. Without a signing key
  // the service is the plain one, which answers curator keys only.
  // A curator key's request was let through without its query being verified: an `expires` in it
  // is the client's word, not a signed URL's, and must not extend the token.
  const auto url_expiry = access_.has_curator_key(req) ? std::nullopt : signed_expiry(req.query);
  if (config_.url_signer)
    links.service_id = base + "/iiif/3/" +
                       config_.url_signer->sign_service(id, url_expiry.value_or(unix_now() + kServiceTokenSeconds));
  Response r = body_response(presentation_type(req), manifest_json(entry->manifest, read_description(*entry), links, config_.iiif));
  r.route = "iiif_manifest";
  r.set_header("Cache-Control", "private, no-store");  // it holds a capability that expires
  return r;
}

std::optional<Response> Router::iiif_collection(const Request& req, const PathParams&, bool may_compute) {
  if (!may_compute) return std::nullopt;  // lists the store
  Response r = body_response(presentation_type(req), collection_json(base_url(req), collection_.current()->size()));
  r.route = "iiif_collection";
  r.set_header("Cache-Control", "no-cache");
  return r;
}

std::optional<Response> Router::iiif_collection_page(const Request& req, const PathParams& p, bool may_compute) {
  const auto page = parse_small_uint(param(p, "page"));
  if (!page || *page < 1) throw ApiError(404, "not_found", "collection pages are numbered from 1");
  if (!may_compute) return std::nullopt;
  const auto images = collection_.current();
  const int pages = int((images->size() + kCollectionPageSize - 1) / kCollectionPageSize);
  if (*page > pages)
    throw ApiError(404, "not_found",
                   "the collection has " + std::to_string(pages) + " page" + (pages == 1 ? "" : "s"));
  std::vector<CollectionEntry> listed;
  const std::size_t first = std::size_t(*page - 1) * kCollectionPageSize;
  for (std::size_t i = first; i < std::min(images->size(), first + kCollectionPageSize); ++i)
    listed.push_back({&(*images)[i].image->manifest, (*images)[i].description});
  Response r = body_response(presentation_type(req), collection_page_json(base_url(req), *page, pages, listed));
  r.route = "iiif_collection";
  r.set_header("Cache-Control", "no-cache");
  return r;
}

}  // namespace zoomwarp::api
