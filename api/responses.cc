#include "api/responses.h"

#include "api/errors.h"
#include "tiles/image_id.h"

namespace zoomwarp::api {

Response body_response(std::string content_type, std::string body) {
  Response r;
  r.content_type = std::move(content_type);
  r.body = std::make_shared<const std::string>(std::move(body));
  return r;
}

std::shared_ptr<const tiles::ImageEntry> find_image(const tiles::Store& store, const std::string& id) {
  if (!tiles::is_valid_image_id(id))
    throw ApiError(400, "invalid_id",
                   "image ids are 1-128 characters from A-Z a-z 0-9 . _ - and start with a letter or digit");
  auto entry = store.find(id);
  if (!entry) throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
  return entry;
}

}  // namespace zoomwarp::api
