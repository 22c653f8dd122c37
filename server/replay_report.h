// What `zoomwarp replay` measures and how it reports it, for replay_command.cc (its only user):
// the series a request counts in (one endpoint × one action kind), the tally each client keeps,
// the clients' tallies merged into a Summary, and the summary printed as a table or as one JSON
// object (the shapes tests/load/README.md and tests/http/http_replay_test.cc read).
//
// Threads: a client thread records only into its own Tally; summarize() and the printing run on
// the command's thread once the clients have finished.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "server/view_path.h"

namespace zoomwarp::server::replay {

enum class Endpoint { kMesh, kViewport };
constexpr std::array<const char*, 2> kEndpointNames = {"mesh", "viewport"};

// Statistics are kept per series: one endpoint × one action kind.
constexpr int kSeries = 4;
inline int series_of(Endpoint e, ViewAction::Kind k) { return int(e) * 2 + int(k); }

inline bool succeeded(int status) { return status >= 200 && status < 300; }

struct SeriesStats {
  std::int64_t requests = 0, errors = 0;
  std::vector<float> ms;  // latencies of the successful requests; floats halve a long run's memory
};

// What a client measured. Each client keeps its own, so the hot loop shares nothing; the summary
// merges them.
struct Tally {
  std::array<SeriesStats, kSeries> series;
  std::map<std::string, std::int64_t> errors_by_status;  // "503", "connection", …

  void record(int s, int status, double ms);  // status 0: no answer, the connection failed
  void merge(const Tally& other);
};

struct Summary {
  Tally tally;  // all clients', latencies sorted
  std::int64_t requests = 0, errors = 0;
  double seconds = 0;
  std::string first_connection_error;
};

// The clients' tallies merged, each series' latencies sorted for the percentiles, the totals.
Summary summarize(const std::vector<Tally>& tallies, double seconds, std::string first_connection_error);

// What was replayed, as the summary names it; the command's Config adds how to reach the server
// and how long to go on.
struct Workload {
  std::string image;
  std::vector<std::string> paths;
  std::string method;
  std::string fit = "auto";      // fit= of every view (warp/window/fit.h)
  std::string max_distortion;    // max_distortion= when given; empty: the server's default
  std::vector<Endpoint> endpoints;  // each action's requests in this order; the report's rows too
  int clients = 4;
};

// On stdout: the totals, then for each series that saw requests (endpoint by endpoint) its
// requests, errors and p50/p95/p99 latency by nearest rank; as one JSON object, or as a table.
void print_summary_json(const Summary& s, const Workload& w);
void print_summary(const Summary& s, const Workload& w, std::size_t actions);

}  // namespace zoomwarp::server::replay
