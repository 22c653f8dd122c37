// A short memory of failed computations (issue 17): after a view ran out of time or tripped an
// internal error, the same (image version, canonical request) asked again within the window is
// answered with the remembered failure at once, instead of pinning another worker until its
// deadline — a client's retry loop then costs one computation per window, not one per retry.
//
// Bounded in bytes like the response cache (tiles/byte_lru_cache.h): the key (at most the 16 KiB
// header limit) and the small error body count, least recently used entries go first, so a flood
// of distinct failing requests costs at most `max_bytes`. Expired entries are never answered; they
// stay until replaced or evicted.
//
// Threads: every member may be called from any thread (the cache locks inside).
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>

#include "api/http_types.h"
#include "tiles/byte_lru_cache.h"

namespace zoomwarp::api {

class FailureCache {
 public:
  using Clock = std::chrono::steady_clock;

  // `window` 0 disables the cache: nothing is remembered.
  FailureCache(std::chrono::milliseconds window, std::size_t max_bytes) : window_(window), entries_(max_bytes) {}

  // Remembers `failure` (its status, headers and body; not its log detail, logged once already)
  // until `now` + window, replacing what `key` held.
  void put(const std::string& key, Response failure, Clock::time_point now = Clock::now());

  // The failure remembered under `key` if its window has not passed: the same status, headers and
  // body, with Retry-After the window's remaining whole seconds (at least 1), `failure` =
  // "negative_cache" and `cache` = "negative" for the metrics and the request log.
  std::optional<Response> get(const std::string& key, Clock::time_point now = Clock::now());

  std::size_t bytes() const { return entries_.stats().bytes; }  // for the metrics

 private:
  struct Entry {
    Response failure;
    Clock::time_point expires;
  };
  const std::chrono::milliseconds window_;
  tiles::ByteLruCache<Entry> entries_;
};

}  // namespace zoomwarp::api
