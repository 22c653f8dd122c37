#include "api/failure_cache.h"

#include <algorithm>

namespace zoomwarp::api {

void FailureCache::put(const std::string& key, Response failure, Clock::time_point now) {
  if (window_.count() == 0) return;
  failure.log_detail.clear();
  std::erase_if(failure.headers, [](const auto& h) { return h.first == "Retry-After"; });
  const std::size_t bytes = (failure.body ? failure.body->size() : 0) + sizeof(Response);
  entries_.put(key, std::make_shared<const Entry>(Entry{std::move(failure), now + window_}), bytes);
}

std::optional<Response> FailureCache::get(const std::string& key, Clock::time_point now) {
  if (window_.count() == 0) return std::nullopt;
  const auto entry = entries_.get(key);
  if (!entry || now >= entry->expires) return std::nullopt;
  Response r = entry->failure;
  // Whole seconds, rounded up: a client waiting that long finds the window passed.
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(entry->expires - now);
  r.set_header("Retry-After", std::to_string(std::max<long long>(1, (left.count() + 999) / 1000)));
  r.failure = "negative_cache";
  r.cache = "negative";
  return r;
}

}  // namespace zoomwarp::api
