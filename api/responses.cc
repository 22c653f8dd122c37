#include "api/responses.h"

#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "tiles/image_id.h"

namespace zoomwarp::api {

Response body_response(std::string content_type, std::string body) {
  Response r;
  r.content_type = std::move(content_type);
  r.body = std::make_shared<const std::string>(std::move(body));
  return r;
}

Response json_response(int status, const nlohmann::json& body) {
  Response r = body_response("application/json", body.dump(2) + "\n");
  r.status = status;
  return r;
}

void check_image_id(const std::string& id) {
  if (!tiles::is_valid_image_id(id))
    throw ApiError(400, "invalid_id",
                   "image ids are 1-128 characters from A-Z a-z 0-9 . _ - and start with a letter or digit");
}

std::shared_ptr<const tiles::ImageEntry> find_image(const tiles::Store& store, const std::string& id) {
  check_image_id(id);
  auto entry = store.find(id);
  if (!entry && store.published(id))
    throw ApiError(500, "image_damaged",
                   "image '" + id + "' is published but its manifest cannot be read; DELETE it or ingest it again");
  if (!entry) throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
  return entry;
}

}  // namespace zoomwarp::api
