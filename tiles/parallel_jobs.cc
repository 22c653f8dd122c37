#include "tiles/parallel_jobs.h"

#include <algorithm>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace zoomwarp::tiles {

void run_jobs(std::span<const Job> jobs, int threads, std::size_t memory_budget) {
  std::mutex mutex;
  std::condition_variable finished;  // a job finished: more may fit now
  std::vector<bool> started(jobs.size(), false);
  std::vector<std::exception_ptr> errors(jobs.size());
  std::size_t not_started = jobs.size(), running = 0, running_bytes = 0;

  // Takes the first job that fits, runs it, and again, until every job has been started.
  const auto take_jobs = [&] {
    std::unique_lock lock(mutex);
    while (not_started > 0) {
      std::size_t pick = 0;
      while (pick < jobs.size() &&
             (started[pick] || (running > 0 && running_bytes + jobs[pick].peak_bytes > memory_budget)))
        ++pick;
      if (pick == jobs.size()) {
        finished.wait(lock);
        continue;
      }
      started[pick] = true;
      --not_started, ++running, running_bytes += jobs[pick].peak_bytes;
      lock.unlock();
      try {
        jobs[pick].run();
      } catch (...) {
        errors[pick] = std::current_exception();
      }
      lock.lock();
      --running, running_bytes -= jobs[pick].peak_bytes;
      finished.notify_all();
    }
  };
  const int helpers = std::clamp(threads, 1, int(std::max<std::size_t>(jobs.size(), 1))) - 1;
  std::vector<std::jthread> pool;
  for (int i = 0; i < helpers; ++i) pool.emplace_back(take_jobs);
  take_jobs();
  pool.clear();  // joins
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace zoomwarp::tiles
