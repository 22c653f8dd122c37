#include "api/errors.h"

#include <cctype>
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

Response error_response(const ApiError& error) {
  Response r = error_response(error.status(), error.code(), error.what());
  r.log_detail = error.log_detail();
  if (error.retry_after() > 0) r.set_header("Retry-After", std::to_string(error.retry_after()));
  if (error.status() == 500) r.failure = "internal_error";
  return r;
}

Response internal_error_response(const std::string& detail) {
  Response r = error_response(500, "internal_error", "the server could not answer this request; it has logged why");
  r.log_detail = detail;
  r.failure = "internal_error";
  return r;
}

Response stopped_response(warp::Stopped::Reason reason) {
  const bool deadline = reason == warp::Stopped::Reason::kDeadline;
  Response r = deadline ? error_response(503, "deadline_exceeded",
                                         "the request took longer than the server allows; retry, or ask for a smaller view")
                        : error_response(503, "request_cancelled", "the request was cancelled");
  r.set_header("Retry-After", "1");
  r.failure = deadline ? "deadline" : "cancelled";
  return r;
}

Response store_unavailable_response(const tiles::StoreUnavailable& error) {
  Response r = error.timed_out()
                   ? error_response(504, "store_timeout", "the image store did not answer in time; retry shortly")
                   : error_response(503, "store_unavailable", "the image store cannot be reached; retry shortly");
  r.set_header("Retry-After", "1");
  r.failure = "store";
  r.log_detail = error.what();
  return r;
}

std::optional<Response> server_failure_response(std::exception_ptr error) {
  try {
    std::rethrow_exception(error);
  } catch (const warp::Stopped& stopped) {
    return stopped_response(stopped.reason());
  } catch (const tiles::StoreUnavailable& e) {
    return store_unavailable_response(e);
  } catch (const ApiError& e) {
    if (e.status() == 500) return error_response(e);
  } catch (const std::exception& e) {
    return internal_error_response(e.what());
  }
  return std::nullopt;
}

std::string without_paths(const std::string& message) {
  std::string out;
  for (std::size_t i = 0; i < message.size();) {
    const bool starts_path = message[i] == '/' && (i == 0 || std::isspace(static_cast<unsigned char>(message[i - 1])) ||
                                                   message[i - 1] == '"' || message[i - 1] == '\'' ||
                                                   message[i - 1] == '(' || message[i - 1] == '=');
    if (!starts_path) {
      out.push_back(message[i++]);
      continue;
    }
    while (i < message.size() && !std::isspace(static_cast<unsigned char>(message[i])) && message[i] != '"' &&
           message[i] != '\'' && message[i] != ')' && message[i] != ':')
      ++i;
    out += "(file)";
  }
  return out;
}

}  // namespace zoomwarp::api
