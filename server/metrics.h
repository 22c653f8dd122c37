// Prometheus metrics (text exposition format 0.0.4): request counts by route and status, latency
// histograms by route, requests failed on the server's side by route and reason, plus gauges the
// caller samples at scrape time (caches, queue, store).
//
// Threads: every member function may be called from any thread; samplers are called without the
// lock held, from the thread calling render().
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <utility>

namespace zoomwarp::server {

class Metrics {
 public:
  void observe_request(const std::string& route, int status, double seconds);
  // A request that failed on the server's side (api::Response::failure): reason "deadline",
  // "cancelled", "internal_error" or "negative_cache". Routes are the router's labels, never paths.
  void observe_failure(const std::string& route, const std::string& reason);
  // Uploads let through the rate limits, and refused by one ("uploads_per_minute",
  // "bytes_per_day"), by key id ("" for requests without a valid key: never per address, whose
  // number is unbounded).
  void observe_upload(const std::string& key_id);
  void observe_rate_limited(const std::string& key_id, const std::string& limit);

  // A gauge or counter sampled at each scrape: name, help, type ("gauge"/"counter"), labels
  // (e.g. R"(cache="response")" or ""), value.
  struct Sample {
    std::string name, help, type, labels;
    double value;
  };
  using Sampler = std::function<std::vector<Sample>()>;
  void add_sampler(Sampler s);

  std::string render() const;

 private:
  static constexpr std::array<double, 14> kBuckets = {0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05,
                                                      0.1,    0.25,  0.5,    1,     2.5,  5,    10};
  struct Histogram {
    std::array<std::uint64_t, kBuckets.size()> buckets{};
    std::uint64_t count = 0;
    double sum = 0;
  };
  mutable std::mutex mu_;
  std::map<std::pair<std::string, int>, std::uint64_t> requests_;
  std::map<std::string, Histogram> latency_;
  std::map<std::pair<std::string, std::string>, std::uint64_t> failed_;
  std::map<std::string, std::uint64_t> uploads_;
  std::map<std::pair<std::string, std::string>, std::uint64_t> rate_limited_;
  std::vector<Sampler> samplers_;
};

}  // namespace zoomwarp::server
