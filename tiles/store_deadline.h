// How long a store operation may take on this thread (issue 29). A bucket store's requests are
// bounded by a deadline; the Store's callers (a request's worker, an ingest, a command) do not
// pass one through every call, they set it for the thread instead:
//
//   StoreDeadlineScope scope(request_deadline);   // every store call on this thread ends by then
//
// Without a scope, an operation gets the store's own budget. Scopes nest; the earliest wins.
// Thread safety: each thread has its own.
#pragma once

#include <algorithm>
#include <chrono>

namespace zoomwarp::tiles {

class StoreDeadlineScope {
 public:
  using Clock = std::chrono::steady_clock;

  explicit StoreDeadlineScope(Clock::time_point deadline) : previous_(current_) {
    current_ = std::min(current_, deadline);
  }
  ~StoreDeadlineScope() { current_ = previous_; }
  StoreDeadlineScope(const StoreDeadlineScope&) = delete;
  StoreDeadlineScope& operator=(const StoreDeadlineScope&) = delete;

  // The deadline of an operation starting now that may take `budget` at most.
  static Clock::time_point deadline(Clock::duration budget) { return std::min(current_, Clock::now() + budget); }

 private:
  static inline thread_local Clock::time_point current_ = Clock::time_point::max();
  Clock::time_point previous_;
};

}  // namespace zoomwarp::tiles
