// Small pieces every route file of the api uses.
#pragma once

#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "api/http_types.h"
#include "tiles/store.h"

namespace zoomwarp::api {

Response body_response(std::string content_type, std::string body);

// `body` as indented JSON (a newline at the end), with `status`.
Response json_response(int status, const nlohmann::json& body);

// ApiError 400 unless `id` is a valid image id.
void check_image_id(const std::string& id);

// The published image `id`; ApiError 400 for an invalid id, 404 for an unknown one, 500
// "image_damaged" for one that is published but whose manifest cannot be read.
std::shared_ptr<const tiles::ImageEntry> find_image(const tiles::Store& store, const std::string& id);

}  // namespace zoomwarp::api
