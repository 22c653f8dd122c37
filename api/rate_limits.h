// Upload rate limits per client: uploads per minute and upload bytes per day, each a token bucket
// (the full budget may be spent at once, and it refills evenly: N uploads per minute is one every
// 60/N seconds once the burst is used). A client is a string the caller chooses — the server uses
// "key:ID" for a request with a valid API key and "address:IP" for one without — so one key is
// limited wherever it comes from, and anonymous clients each by their address.
//
// Memory is bounded: at most `max_clients` clients are tracked. A client whose buckets have
// refilled is forgotten when room is needed (it carries no information); if every tracked client
// is still limited, the one seen longest ago is forgotten, which gives it a fresh budget — the
// price of the bound, paid by the oldest entry rather than by refusing new clients.
//
// Threads: admit() and tracked_clients() may be called from any threads at once (one mutex; an
// admission is a map lookup and some arithmetic, once per upload).
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>

namespace zoomwarp::api {

struct RateLimitConfig {
  std::uint64_t uploads_per_minute = 0;  // 0: no limit
  std::uint64_t bytes_per_day = 0;       // 0: no limit
  std::size_t max_clients = 100000;      // clients tracked at once
};

class RateLimits {
 public:
  using Clock = std::chrono::steady_clock;

  explicit RateLimits(RateLimitConfig config);

  // Which limit refused an upload ("uploads_per_minute" or "bytes_per_day"), and in how many whole
  // seconds (≥ 1) it would be admitted. An upload larger than the daily budget is never admitted;
  // it gets a day.
  struct Refusal {
    std::string_view limit;
    std::int64_t retry_after_seconds = 1;
  };

  // Takes one upload of `bytes` from `client`'s budgets at `now`, or, if either limit refuses it,
  // takes nothing and says why.
  std::optional<Refusal> admit(const std::string& client, std::uint64_t bytes, Clock::time_point now);

  std::size_t tracked_clients() const;

 private:
  struct Budget {
    double uploads = 0;  // tokens left
    double bytes = 0;
    Clock::time_point updated;  // of the token counts
    Clock::time_point seen;     // the client's last admit(): who is forgotten first
  };
  void refill(Budget& b, Clock::time_point now) const;
  bool is_full(const Budget& b) const;
  void make_room(Clock::time_point now);

  const RateLimitConfig config_;
  mutable std::mutex mu_;
  std::unordered_map<std::string, Budget> clients_;
};

}  // namespace zoomwarp::api
