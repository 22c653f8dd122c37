#include "tiles/parallel_jobs.h"

#include <algorithm>
#include <vector>

#include "tiles/helping_wait.h"

namespace zoomwarp::tiles {

void run_jobs(std::span<const std::function<void()>> jobs, int threads) {
  const int helpers = std::clamp(threads, 1, int(std::max<std::size_t>(jobs.size(), 1))) - 1;
  OIIO::thread_pool pool(helpers);  // 0 helpers: push() runs the job at once
  std::vector<std::future<void>> done;
  done.reserve(jobs.size());
  for (const auto& job : jobs) done.push_back(pool.push([&job](int) { job(); }));
  for (auto& f : done) wait_helping(pool, f);
  for (auto& f : done) f.get();
}

}  // namespace zoomwarp::tiles
