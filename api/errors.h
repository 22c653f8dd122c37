// Every error leaves the api as a JSON body {"error": {"code", "message"}} with an HTTP status
// that says whose fault it was. Routes throw ApiError; the router turns it into a Response.
//
// Messages are for the client: they never carry a file path, the host name or the process id
// (library and file-system errors do). What the operator needs goes into Response::log_detail,
// which the server logs and never sends.
#pragma once

#include <exception>
#include <optional>
#include <stdexcept>
#include <string>

#include "api/http_types.h"
#include "tiles/store_errors.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::api {

class ApiError : public std::runtime_error {
 public:
  ApiError(int status, std::string code, const std::string& message, std::string log_detail = {})
      : std::runtime_error(message), status_(status), code_(std::move(code)), log_detail_(std::move(log_detail)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }
  const std::string& log_detail() const { return log_detail_; }
  // Seconds for a Retry-After header (429, 503); 0: none.
  int retry_after() const { return retry_after_; }
  ApiError&& with_retry_after(int seconds) && {
    retry_after_ = seconds;
    return std::move(*this);
  }

 private:
  int status_;
  std::string code_;
  std::string log_detail_;
  int retry_after_ = 0;
};

Response error_response(int status, const std::string& code, const std::string& message);

// The answer to an ApiError: its status, code and message, its log detail; a 500 is marked
// Response::failure = "internal_error".
Response error_response(const ApiError& error);

// 500 for an unexpected exception: a generic message; `detail` (e.what()) only in the log.
// Response::failure = "internal_error".
Response internal_error_response(const std::string& detail);

// 503 + Retry-After for a request whose StopToken ended it: "deadline_exceeded" when it ran out
// of time, "request_cancelled" when its client went away or the server is shutting down.
// Response::failure says which ("deadline", "cancelled"), for metrics and the log.
Response stopped_response(warp::Stopped::Reason reason);

// 503 (504 when it timed out) + Retry-After when the store did not answer (a bucket that is down,
// hung or throttling): "store_unavailable" / "store_timeout"; Response::failure "store".
Response store_unavailable_response(const tiles::StoreUnavailable& error);

// The answer to a computation that threw, when the failure is the server's: stopped_response()
// for warp::Stopped, store_unavailable_response() for tiles::StoreUnavailable, error_response() for an ApiError of status 500, internal_error_response()
// for any other std::exception. nullopt for an ApiError of another status: the client's own error
// (or a refusal such as 501), which the caller rethrows for the router to answer as usual.
std::optional<Response> server_failure_response(std::exception_ptr error);

// `message` with every absolute path in it ("/var/lib/…/upload", "'/tmp/x.png'") replaced by
// "(file)", for library messages (OpenImageIO) that are useful to a client but name files.
std::string without_paths(const std::string& message);

}  // namespace zoomwarp::api
