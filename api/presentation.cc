#include "api/presentation.h"

#include <algorithm>

#include <nlohmann/json.hpp>

namespace zoomwarp::api {

namespace {

// Ordered, so that @context, id, type and label come first, as in the specification's examples.
using Json = nlohmann::ordered_json;

constexpr const char* kContext = "http://iiif.io/api/presentation/3/context.json";
constexpr int kThumbnailBox = 400;

Json none_map(const std::string& text) { return {{"none", {text}}}; }

Json image_service(const std::string& service_id) {
  return Json::array({{{"id", service_id}, {"type", "ImageService3"}, {"profile", "level2"}}});
}

// The whole image at the first pyramid level within the thumbnail box: a size the service answers
// from that level (the image's own size when it is small).
Json thumbnail(const tiles::Manifest& m, const std::string& service_id) {
  int k = 0;
  while (k + 1 < m.levels && (m.level_width(k) > kThumbnailBox || m.level_height(k) > kThumbnailBox)) ++k;
  const int w = m.level_width(k), h = m.level_height(k);
  return Json::array({{{"id", service_id + "/full/" + std::to_string(w) + "," + std::to_string(h) + "/0/default.jpg"},
                       {"type", "Image"},
                       {"format", "image/jpeg"},
                       {"width", w},
                       {"height", h},
                       {"service", image_service(service_id)}}});
}

Json label_of(const tiles::Manifest& m, const Description& d) {
  return d.label.empty() ? none_map(m.id) : Json::parse(description_json(d))["label"];
}

}  // namespace

std::string manifest_path(const std::string& id) { return "/iiif/presentation/3/" + id + "/manifest"; }
std::string collection_path() { return "/iiif/presentation/3/collection"; }
std::string collection_page_path(int page) { return collection_path() + "/" + std::to_string(page); }

std::string manifest_json(const tiles::Manifest& m, const Description& d, const ManifestLinks& links,
                          const IiifLimits& limits) {
  const std::string id = links.base + manifest_path(m.id);
  const std::string canvas = links.base + "/iiif/presentation/3/" + m.id + "/canvas/1";
  // The painting body: the service's `max`, the largest size its limits let it send whole.
  const IiifPlan max = plan_iiif_request("full", "max", "0", "default.jpg", m.width, m.height, limits);
  Json manifest = {{"@context", kContext}, {"id", id}, {"type", "Manifest"}, {"label", label_of(m, d)}};
  // summary, metadata, rights, requiredStatement: the curator's, in their IIIF form already.
  const Json described = Json::parse(description_json(d));
  for (const auto& [name, value] : described.items())
    if (name != "label") manifest[name] = value;
  manifest["thumbnail"] = thumbnail(m, links.service_id);
  manifest["seeAlso"] = Json::array({{{"id", links.base + "/v1/images/" + m.id},
                                      {"type", "Dataset"},
                                      {"label", none_map("zoomwarp image record")},
                                      {"format", "application/json"}}});
  if (links.in_collection)
    manifest["partOf"] = Json::array({{{"id", links.base + collection_path()}, {"type", "Collection"}}});
  manifest["items"] = Json::array({{
      {"id", canvas},
      {"type", "Canvas"},
      {"width", m.width},
      {"height", m.height},
      {"items",
       Json::array({{{"id", canvas + "/page"},
                     {"type", "AnnotationPage"},
                     {"items",
                      Json::array({{{"id", canvas + "/page/image"},
                                    {"type", "Annotation"},
                                    {"motivation", "painting"},
                                    {"body",
                                     {{"id", links.service_id + "/full/max/0/default.jpg"},
                                      {"type", "Image"},
                                      {"format", "image/jpeg"},
                                      {"width", max.width},
                                      {"height", max.height},
                                      {"service", image_service(links.service_id)}}},
                                    {"target", canvas}}})}}})},
  }});
  return manifest.dump(2) + "\n";
}

std::string collection_json(const std::string& base, std::size_t count) {
  Json pages = Json::array();
  const std::size_t n = (count + kCollectionPageSize - 1) / kCollectionPageSize;
  for (std::size_t p = 1; p <= n; ++p) {
    const std::size_t first = (p - 1) * kCollectionPageSize + 1, last = std::min(count, p * kCollectionPageSize);
    pages.push_back({{"id", base + collection_page_path(int(p))},
                     {"type", "Collection"},
                     {"label", none_map("Images " + std::to_string(first) + "–" + std::to_string(last) + " of " +
                                        std::to_string(count))}});
  }
  const Json collection = {{"@context", kContext},
                           {"id", base + collection_path()},
                           {"type", "Collection"},
                           {"label", none_map("zoomwarp images")},
                           {"summary", none_map(std::to_string(count) + " public images, " +
                                                std::to_string(kCollectionPageSize) + " per page")},
                           {"items", pages}};
  return collection.dump(2) + "\n";
}

std::string collection_page_json(const std::string& base, int page, int pages,
                                 const std::vector<CollectionEntry>& images) {
  Json items = Json::array();
  for (const CollectionEntry& e : images)
    items.push_back({{"id", base + manifest_path(e.image->id)},
                     {"type", "Manifest"},
                     {"label", label_of(*e.image, e.description)},
                     {"thumbnail", thumbnail(*e.image, base + "/iiif/3/" + e.image->id)}});
  const Json collection = {{"@context", kContext},
                           {"id", base + collection_page_path(page)},
                           {"type", "Collection"},
                           {"label", none_map("zoomwarp images, page " + std::to_string(page) + " of " +
                                              std::to_string(pages))},
                           {"partOf", Json::array({{{"id", base + collection_path()}, {"type", "Collection"}}})},
                           {"items", items}};
  return collection.dump(2) + "\n";
}

}  // namespace zoomwarp::api
