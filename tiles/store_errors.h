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
  StoreUnavailable(const std::string& what, bool timed_out, bool known_down = false)
      : std::runtime_error(what), timed_out_(timed_out), known_down_(known_down) {}
  bool timed_out() const { return timed_out_; }
  // Not asked: the store failed its last readiness check (a server's monitor), so nothing was
  // sent. What the caller held from the store before may stand in for the answer.
  bool known_down() const { return known_down_; }

 private:
  bool timed_out_, known_down_;
};

}  // namespace zoomwarp::tiles
