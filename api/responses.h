// Small pieces every route file of the api uses.
#pragma once

#include <memory>
#include <string>

#include "api/http_types.h"
#include "tiles/store.h"

namespace zoomwarp::api {

Response body_response(std::string content_type, std::string body);

// The published image `id`; ApiError 400 for an invalid id, 404 for an unknown one.
std::shared_ptr<const tiles::ImageEntry> find_image(const tiles::Store& store, const std::string& id);

}  // namespace zoomwarp::api
