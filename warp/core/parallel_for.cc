#include "warp/core/parallel_for.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <thread>
#include <vector>

#include "tiles/parallel_jobs.h"

namespace zoomwarp::warp {

int analysis_parallelism() {
  static const int threads = std::clamp(int(std::thread::hardware_concurrency()), 1, 4);
  return threads;
}

// Ingest's job runner (tiles/parallel_jobs.h) with no memory budget: it starts its threads from
// the caller for the call. Once a body has thrown, the indices not yet begun return at once.
void parallel_for(int n, const std::function<void(int)>& body) {
  std::atomic<bool> failed{false};
  std::vector<tiles::Job> jobs;
  jobs.reserve(std::size_t(std::max(n, 0)));
  for (int i = 0; i < n; ++i)
    jobs.push_back({[&, i] {
      if (failed) return;
      try {
        body(i);
      } catch (...) {
        failed = true;
        throw;
      }
    }});
  tiles::run_jobs(jobs, analysis_parallelism(), std::numeric_limits<std::size_t>::max());
}

}  // namespace zoomwarp::warp
