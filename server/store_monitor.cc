#include "server/store_monitor.h"

#include <nlohmann/json.hpp>

#include "server/log.h"
#include "tiles/store_deadline.h"

namespace zoomwarp::server {

StoreMonitor::StoreMonitor(const tiles::Store& store, std::chrono::milliseconds interval, std::chrono::milliseconds within)
    : store_(store), interval_(interval), within_(within) {
  check(true);
  thread_ = std::thread([this] { run(); });
}

StoreMonitor::~StoreMonitor() {
  {
    std::lock_guard lock(mu_);
    stopping_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

StoreMonitor::Reading StoreMonitor::last() const {
  std::lock_guard lock(mu_);
  return last_;
}

void StoreMonitor::check(bool count_images) {
  Reading r;
  r.problem = store_.problem(within_);
  if (r.problem.empty() && count_images) {
    try {
      const tiles::StoreDeadlineScope scope(std::chrono::steady_clock::now() + 10 * within_);
      r.images = store_.count();
    } catch (const std::exception& e) {
      r.problem = e.what();
    }
  }
  r.at = std::chrono::steady_clock::now();
  std::lock_guard lock(mu_);
  if (r.problem.empty() != last_.problem.empty())
    log_event(r.problem.empty() ? "info" : "warning", r.problem.empty() ? "store readable" : "store not readable",
              {{"store", store_.root()}, {"problem", r.problem}});
  if (!count_images) r.images = last_.images;
  last_ = std::move(r);
}

void StoreMonitor::run() {
  for (int round = 1;; ++round) {
    {
      std::unique_lock lock(mu_);
      if (wake_.wait_for(lock, interval_, [this] { return stopping_; })) return;
    }
    check(round % 10 == 0);
  }
}

}  // namespace zoomwarp::server
