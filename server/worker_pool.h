// A fixed set of threads for CPU work (decode, resample, encode, ingest), off the I/O threads,
// with a bounded queue: when it is full, try_submit() refuses and the caller answers 503 instead
// of letting latency grow without bound.
//
// Threads: try_submit(), queued(), running() and accepted() may be called from any thread; jobs run on the
// pool's threads. The pool does not look into jobs: a job whose request ran out of time or was
// cancelled while queued still runs, and ends at once (the router checks the request's StopToken
// before computing anything).
#pragma once

#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <vector>

namespace zoomwarp::server {

class WorkerPool {
 public:
  // `nice` > 0 lowers the threads' CPU priority by that much (Linux nice values are per thread,
  // and threads they start inherit them): their work then yields to the process's other threads.
  WorkerPool(int threads, std::size_t max_queue, int nice = 0);
  ~WorkerPool();  // finishes queued jobs, then joins
  WorkerPool(const WorkerPool&) = delete;
  WorkerPool& operator=(const WorkerPool&) = delete;

  bool try_submit(std::function<void()> job);

  std::size_t queued() const;   // waiting, not yet running
  std::size_t running() const;  // being run now
  std::uint64_t accepted() const;  // jobs try_submit() has taken since the start (a metrics counter)

 private:
  void run();

  const std::size_t max_queue_;
  const int nice_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  std::deque<std::function<void()>> queue_;
  std::size_t running_ = 0;
  std::uint64_t accepted_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

}  // namespace zoomwarp::server
