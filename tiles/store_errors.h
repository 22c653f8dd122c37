// What a store's callers tell apart from other failures (issue 29).
#pragma once

#include <stdexcept>
#include <string>

namespace zoomwarp::tiles {

// The store did not answer, or not in time (a bucket that is down, hung or throttling past the
// retries): nothing is wrong with the request or the image, and asking again later may work. The
// server answers 503, or 504 when `timed_out` (api/errors.h), with Retry-After.
class StoreUnavailable : public std::runtime_error {
 public:
  StoreUnavailable(const std::string& what, bool timed_out) : std::runtime_error(what), timed_out_(timed_out) {}
  bool timed_out() const { return timed_out_; }

 private:
  bool timed_out_;
};

}  // namespace zoomwarp::tiles
