// Every error leaves the api as a JSON body {"error": {"code", "message"}} with an HTTP status
// that says whose fault it was. Routes throw ApiError; the router turns it into a Response.
#pragma once

#include <stdexcept>
#include <string>

#include "api/http_types.h"

namespace zoomwarp::api {

class ApiError : public std::runtime_error {
 public:
  ApiError(int status, std::string code, const std::string& message)
      : std::runtime_error(message), status_(status), code_(std::move(code)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }

 private:
  int status_;
  std::string code_;
};

Response error_response(int status, const std::string& code, const std::string& message);

}  // namespace zoomwarp::api
