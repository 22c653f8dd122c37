// A request's budget: a deadline and a cancel flag. Work that a client controls (a view, a
// render) checks it at step boundaries and stops by throwing `Stopped`, so a request that runs
// out of time, or whose client hung up, frees its worker within one step.
//
// Threads: cancel() may be called from any thread (the I/O thread that saw the connection close);
// stop_requested() and check() from any thread, typically the worker doing the work. The token
// must outlive the work it is given to.
#pragma once

#include <atomic>
#include <chrono>
#include <stdexcept>

namespace zoomwarp::warp {

class Stopped : public std::runtime_error {
 public:
  enum class Reason { kDeadline, kCancelled };
  explicit Stopped(Reason reason)
      : std::runtime_error(reason == Reason::kDeadline ? "the request ran out of time" : "the request was cancelled"),
        reason_(reason) {}
  Reason reason() const { return reason_; }

 private:
  Reason reason_;
};

class StopToken {
 public:
  using Clock = std::chrono::steady_clock;

  // Never stops unless cancelled.
  StopToken() = default;
  explicit StopToken(Clock::time_point deadline) : deadline_(deadline) {}
  StopToken(const StopToken&) = delete;
  StopToken& operator=(const StopToken&) = delete;

  void cancel() noexcept { cancelled_.store(true, std::memory_order_relaxed); }

  bool stop_requested() const noexcept { return cancelled_.load(std::memory_order_relaxed) || Clock::now() >= deadline_; }

  // Throws Stopped once the token is cancelled or past its deadline.
  void check() const {
    if (cancelled_.load(std::memory_order_relaxed)) throw Stopped(Stopped::Reason::kCancelled);
    if (Clock::now() >= deadline_) throw Stopped(Stopped::Reason::kDeadline);
  }

  Clock::time_point deadline() const { return deadline_; }

 private:
  std::atomic<bool> cancelled_{false};
  Clock::time_point deadline_ = Clock::time_point::max();
};

// Checks `token` if there is one: the form the warp and render steps use.
inline void check_stop(const StopToken* token) {
  if (token) token->check();
}

}  // namespace zoomwarp::warp
