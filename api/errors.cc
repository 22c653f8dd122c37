#include "api/errors.h"

#include <nlohmann/json.hpp>

namespace zoomwarp::api {

Response error_response(int status, const std::string& code, const std::string& message) {
  Response r;
  r.status = status;
  r.content_type = "application/json";
  nlohmann::json j = {{"error", {{"code", code}, {"message", message}}}};
  // Messages may echo input; replace invalid UTF-8 instead of failing to answer.
  r.body = std::make_shared<const std::string>(
      j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace) + "\n");
  r.set_header("Cache-Control", "no-store");
  return r;
}

}  // namespace zoomwarp::api
