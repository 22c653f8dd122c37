// Whether the store can be read, watched on a thread of its own (issue 29). /readyz and /metrics
// are answered on the I/O thread, which must never wait for a store that hangs: they read the last
// answer kept here instead. Every `interval` the monitor asks the store (one small request, given
// up on after `within`) and, every tenth time, counts its images (a bucket's zoomwarp_images gauge:
// a listing is a billed request, and slow when the store is).
//
// Thread safety: last() from any thread; construct and destroy on one.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <mutex>
#include <string>
#include <thread>

#include "tiles/store.h"

namespace zoomwarp::server {

class StoreMonitor {
 public:
  struct Reading {
    std::string problem;      // "" when the store answered
    std::size_t images = 0;   // at the last count
    std::chrono::steady_clock::time_point at;
  };

  // Asks the store once before returning (start-up waits `within` at most), then every `interval`.
  StoreMonitor(const tiles::Store& store, std::chrono::milliseconds interval, std::chrono::milliseconds within);
  ~StoreMonitor();  // stops the thread; waits for a check in progress (`within` at most)
  StoreMonitor(const StoreMonitor&) = delete;
  StoreMonitor& operator=(const StoreMonitor&) = delete;

  Reading last() const;

 private:
  void check(bool count_images);
  void run();

  const tiles::Store& store_;
  const std::chrono::milliseconds interval_, within_;
  mutable std::mutex mu_;
  std::condition_variable wake_;
  bool stopping_ = false;
  Reading last_;
  std::thread thread_;
};

}  // namespace zoomwarp::server
