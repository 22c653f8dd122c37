#include "server/replay_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

namespace zoomwarp::server::replay {

namespace {

using nlohmann::json;

constexpr std::array<ViewAction::Kind, 2> kKinds = {ViewAction::Kind::kZoom, ViewAction::Kind::kPan};

// Nearest rank, so that p50 ≤ p95 ≤ p99 always holds and every figure is a measured latency.
double percentile(const std::vector<float>& sorted, double p) {
  const auto rank = std::size_t(std::ceil(p / 100 * double(sorted.size())));
  return sorted[std::max<std::size_t>(rank, 1) - 1];
}

constexpr std::array<double, 3> kPercentiles = {50, 95, 99};

// Calls fn(endpoint, action, stats) for every series that saw requests, endpoint by endpoint.
template <class Fn>
void for_each_series(const Summary& s, const Workload& w, Fn fn) {
  for (Endpoint e : w.endpoints)
    for (ViewAction::Kind k : kKinds)
      if (const SeriesStats& st = s.tally.series[series_of(e, k)]; st.requests > 0)
        fn(kEndpointNames[int(e)], std::string(kind_name(k)), st);
}

}  // namespace

void Tally::record(int s, int status, double ms) {
  SeriesStats& st = series[s];
  ++st.requests;
  if (succeeded(status)) {
    st.ms.push_back(float(ms));
    return;
  }
  ++st.errors;
  ++errors_by_status[status == 0 ? "connection" : std::to_string(status)];
}

void Tally::merge(const Tally& other) {
  for (int s = 0; s < kSeries; ++s) {
    series[s].requests += other.series[s].requests;
    series[s].errors += other.series[s].errors;
    series[s].ms.insert(series[s].ms.end(), other.series[s].ms.begin(), other.series[s].ms.end());
  }
  for (const auto& [status, n] : other.errors_by_status) errors_by_status[status] += n;
}

Summary summarize(const std::vector<Tally>& tallies, double seconds, std::string first_connection_error) {
  Summary s;
  s.seconds = seconds;
  for (const Tally& t : tallies) s.tally.merge(t);
  for (auto& st : s.tally.series) {
    std::sort(st.ms.begin(), st.ms.end());
    s.requests += st.requests;
    s.errors += st.errors;
  }
  s.first_connection_error = std::move(first_connection_error);
  return s;
}

void print_summary_json(const Summary& s, const Workload& w) {
  json endpoints = json::object();
  for_each_series(s, w, [&](const char* endpoint, const std::string& action, const SeriesStats& st) {
    json row = {{"requests", st.requests}, {"errors", st.errors}};
    for (double p : kPercentiles)
      row["p" + std::to_string(int(p)) + "_ms"] =
          st.ms.empty() ? json() : json(std::round(percentile(st.ms, p) * 1000) / 1000);  // to the µs
    endpoints[endpoint][action] = row;
  });
  json out = {{"image", w.image},
              {"paths", w.paths},
              {"method", w.method},
              {"fit", w.fit},
              {"clients", w.clients},
              {"seconds", s.seconds},
              {"requests", s.requests},
              {"errors", s.errors},
              {"requests_per_second", s.requests / s.seconds},
              {"errors_by_status", s.tally.errors_by_status},
              {"endpoints", endpoints}};
  if (!s.first_connection_error.empty()) out["first_connection_error"] = s.first_connection_error;
  std::printf("%s\n", out.dump().c_str());
}

void print_summary(const Summary& s, const Workload& w, std::size_t actions) {
  std::printf("replayed %zu path%s (%zu actions) over %s with %d client%s, method %s, fit %s: %lld requests in %.2f s, "
              "%.1f requests/s, %lld errors\n\n",
              w.paths.size(), w.paths.size() == 1 ? "" : "s", actions, w.image.c_str(), w.clients,
              w.clients == 1 ? "" : "s", w.method.c_str(), w.fit.c_str(), (long long)s.requests, s.seconds, s.requests / s.seconds,
              (long long)s.errors);
  std::printf("%-9s %-6s %9s %7s %8s %8s %8s\n", "endpoint", "action", "requests", "errors", "p50 ms", "p95 ms",
              "p99 ms");
  for_each_series(s, w, [](const char* endpoint, const std::string& action, const SeriesStats& st) {
    std::printf("%-9s %-6s %9lld %7lld", endpoint, action.c_str(), (long long)st.requests, (long long)st.errors);
    for (double p : kPercentiles)
      if (st.ms.empty()) std::printf(" %8s", "-");
      else std::printf(" %8.1f", percentile(st.ms, p));
    std::printf("\n");
  });
  if (s.tally.errors_by_status.empty()) return;
  std::printf("\nerrors:");
  for (const auto& [status, n] : s.tally.errors_by_status) std::printf(" %s x%lld", status.c_str(), (long long)n);
  std::printf("\n");
  if (!s.first_connection_error.empty()) std::printf("first connection error: %s\n", s.first_connection_error.c_str());
}

}  // namespace zoomwarp::server::replay
