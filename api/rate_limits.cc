#include "api/rate_limits.h"

#include <algorithm>
#include <cmath>

namespace zoomwarp::api {

namespace {
constexpr double kMinute = 60, kDay = 86400;

std::int64_t whole_seconds(double s) { return std::max<std::int64_t>(1, std::int64_t(std::ceil(s))); }
}  // namespace

RateLimits::RateLimits(RateLimitConfig config) : config_(config) {}

void RateLimits::refill(Budget& b, Clock::time_point now) const {
  const double dt = std::max(0.0, std::chrono::duration<double>(now - b.updated).count());
  b.uploads = std::min<double>(config_.uploads_per_minute, b.uploads + dt * config_.uploads_per_minute / kMinute);
  b.bytes = std::min<double>(config_.bytes_per_day, b.bytes + dt * config_.bytes_per_day / kDay);
  b.updated = std::max(b.updated, now);
}

bool RateLimits::is_full(const Budget& b) const {
  return b.uploads >= config_.uploads_per_minute && b.bytes >= config_.bytes_per_day;
}

void RateLimits::make_room(Clock::time_point now) {
  for (auto it = clients_.begin(); it != clients_.end();) {
    refill(it->second, now);
    it = is_full(it->second) ? clients_.erase(it) : std::next(it);
  }
  if (clients_.size() < config_.max_clients) return;
  auto oldest = std::min_element(clients_.begin(), clients_.end(),
                                 [](const auto& a, const auto& b) { return a.second.seen < b.second.seen; });
  clients_.erase(oldest);
}

std::optional<RateLimits::Refusal> RateLimits::admit(const std::string& client, std::uint64_t bytes,
                                                     Clock::time_point now) {
  if (config_.uploads_per_minute == 0 && config_.bytes_per_day == 0) return std::nullopt;
  std::lock_guard lock(mu_);
  auto it = clients_.find(client);
  if (it == clients_.end()) {
    if (clients_.size() >= std::max<std::size_t>(1, config_.max_clients)) make_room(now);
    it = clients_.emplace(client, Budget{double(config_.uploads_per_minute), double(config_.bytes_per_day), now, now}).first;
  }
  Budget& b = it->second;
  refill(b, now);
  b.seen = now;
  if (config_.uploads_per_minute > 0 && b.uploads < 1)
    return Refusal{"uploads_per_minute", whole_seconds((1 - b.uploads) * kMinute / config_.uploads_per_minute)};
  if (config_.bytes_per_day > 0 && b.bytes < double(bytes)) {
    const bool never = bytes > config_.bytes_per_day;
    return Refusal{"bytes_per_day",
                   never ? std::int64_t(kDay) : whole_seconds((double(bytes) - b.bytes) * kDay / config_.bytes_per_day)};
  }
  if (config_.uploads_per_minute > 0) b.uploads -= 1;
  if (config_.bytes_per_day > 0) b.bytes -= double(bytes);
  return std::nullopt;
}

std::size_t RateLimits::tracked_clients() const {
  std::lock_guard lock(mu_);
  return clients_.size();
}

}  // namespace zoomwarp::api
