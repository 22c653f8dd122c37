// Work shared by many requests, run to completion in the background whatever happens to the
// request that asked first (issue 28): an image's analysis on first use, a method's warp for a
// new screen size. A request waits for it only as long as its own deadline allows and then
// leaves; the work goes on, and a later request — its retry — finds it done.
//
//   run(key, work)   the future of `work` under `key`: the flight in the air for that key, or a
//                    new one queued for the pool's threads. Once a flight has landed (value or
//                    error) its key is free again: nothing is kept here (callers keep values in
//                    their own caches, e.g. tiles/single_flight.h), and a failure is not
//                    remembered, so the next run() tries again.
//
// The threads run below request priority: each lowers its own nice value (Linux schedules
// threads, so this touches no other thread of the process), so a machine busy with views gives
// the views the CPU first. At most `max_flights` keys are queued or running; run() of a new key
// beyond that throws Busy — the caller answers 503 rather than queue without bound.
//
// Destruction waits for the flight running on each thread and drops those still queued (their
// futures report std::future_error broken_promise).
//
// Thread safety: run() and in_flight() may be called from any thread concurrently; `work` runs
// on one of the pool's threads and must not call run() for a key it is itself computing.
#pragma once

#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <cstddef>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

namespace zoomwarp::tiles {

template <class V>
class BackgroundFlights {
 public:
  using Future = std::shared_future<V>;

  struct Busy : std::runtime_error {
    using std::runtime_error::runtime_error;
  };

  // `threads` ≥ 1 threads, each `nice` levels below the thread constructing it (0: at its level).
  BackgroundFlights(int threads, std::size_t max_flights, int nice = 10) : max_flights_(max_flights) {
    for (int i = 0; i < std::max(1, threads); ++i)
      threads_.emplace_back([this, nice] {
        // Linux schedules threads: this thread alone, `nice` levels below the one that made it.
        const id_t tid = id_t(::gettid());
        if (nice > 0) ::setpriority(PRIO_PROCESS, tid, std::min(19, ::getpriority(PRIO_PROCESS, tid) + nice));
        serve();
      });
  }

  ~BackgroundFlights() {
    {
      std::lock_guard lock(mu_);
      stopping_ = true;
      queue_.clear();  // their promises break: waiters see broken_promise
    }
    wake_.notify_all();
    for (auto& t : threads_) t.join();
  }

  BackgroundFlights(const BackgroundFlights&) = delete;
  BackgroundFlights& operator=(const BackgroundFlights&) = delete;

  // Throws Busy when `key` is new and max_flights keys are already queued or running.
  Future run(const std::string& key, std::function<V()> work) {
    std::lock_guard lock(mu_);
    if (auto it = flights_.find(key); it != flights_.end()) return it->second;
    if (flights_.size() >= max_flights_)
      throw Busy("the server's background work is full (" + std::to_string(max_flights_) + " computations)");
    auto task = std::make_shared<std::packaged_task<V()>>(std::move(work));
    Future future = task->get_future().share();
    flights_.emplace(key, future);
    queue_.push_back({key, std::move(task)});
    wake_.notify_one();
    return future;
  }

  // How many keys are queued or running (for /metrics).
  std::size_t in_flight() const {
    std::lock_guard lock(mu_);
    return flights_.size();
  }

 private:
  struct Queued {
    std::string key;
    std::shared_ptr<std::packaged_task<V()>> task;
  };

  void serve() {
    while (true) {
      Queued next;
      {
        std::unique_lock lock(mu_);
        wake_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
        if (stopping_) return;
        next = std::move(queue_.front());
        queue_.pop_front();
      }
      (*next.task)();  // the value or the exception lands in the future
      std::lock_guard lock(mu_);
      flights_.erase(next.key);
    }
  }

  const std::size_t max_flights_;
  mutable std::mutex mu_;
  std::condition_variable wake_;
  std::deque<Queued> queue_;
  std::unordered_map<std::string, Future> flights_;  // queued or running, by key
  bool stopping_ = false;
  std::vector<std::thread> threads_;  // last: started once the members above exist
};

}  // namespace zoomwarp::tiles
