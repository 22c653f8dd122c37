#include "server/metrics.h"

#include <cmath>
#include <sstream>

namespace zoomwarp::server {

void Metrics::observe_request(const std::string& route, int status, double seconds) {
  std::lock_guard lock(mu_);
  ++requests_[{route, status}];
  Histogram& h = latency_[route];
  for (std::size_t i = 0; i < kBuckets.size(); ++i)
    if (seconds <= kBuckets[i]) ++h.buckets[i];
  ++h.count;
  h.sum += seconds;
}

void Metrics::observe_failure(const std::string& route, const std::string& reason) {
  std::lock_guard lock(mu_);
  ++failed_[{route, reason}];
}

void Metrics::observe_upload(const std::string& key_id) {
  std::lock_guard lock(mu_);
  ++uploads_[key_id];
}

void Metrics::observe_rate_limited(const std::string& key_id, const std::string& limit) {
  std::lock_guard lock(mu_);
  ++rate_limited_[{key_id, limit}];
}

namespace {
// A label value as the exposition format wants it: key ids come from the operator's key file.
std::string escaped(const std::string& v) {
  std::string out;
  for (char c : v) {
    if (c == '\\' || c == '"') out += '\\';
    if (c == '\n') out += "\\n";
    else out += c;
  }
  return out;
}
}  // namespace

void Metrics::add_sampler(Sampler s) {
  std::lock_guard lock(mu_);
  samplers_.push_back(std::move(s));
}

std::string Metrics::render() const {
  std::ostringstream out;
  std::vector<Sampler> samplers;
  {
    std::lock_guard lock(mu_);
    out << "# HELP zoomwarp_http_requests_total HTTP requests answered, by route and status.\n"
           "# TYPE zoomwarp_http_requests_total counter\n";
    for (const auto& [key, n] : requests_)
      out << "zoomwarp_http_requests_total{route=\"" << key.first << "\",status=\"" << key.second
          << "\"} " << n << "\n";
    out << "# HELP zoomwarp_http_request_duration_seconds Time from a complete request to its response.\n"
           "# TYPE zoomwarp_http_request_duration_seconds histogram\n";
    for (const auto& [route, h] : latency_) {
      for (std::size_t i = 0; i < kBuckets.size(); ++i)
        out << "zoomwarp_http_request_duration_seconds_bucket{route=\"" << route << "\",le=\""
            << kBuckets[i] << "\"} " << h.buckets[i] << "\n";
      out << "zoomwarp_http_request_duration_seconds_bucket{route=\"" << route << "\",le=\"+Inf\"} "
          << h.count << "\n"
          << "zoomwarp_http_request_duration_seconds_sum{route=\"" << route << "\"} " << h.sum << "\n"
          << "zoomwarp_http_request_duration_seconds_count{route=\"" << route << "\"} " << h.count << "\n";
    }
    out << "# HELP zoomwarp_http_requests_failed_total Requests failed on the server's side, by route and reason"
           " (deadline: --request-timeout passed, 503; cancelled: the client left, or the drain timed out, 503;"
           " internal_error: 500; store: the image store did not answer, 503/504; negative_cache: a view's recent deadline or 500 answered again, --failure-cache-ms).\n"
           "# TYPE zoomwarp_http_requests_failed_total counter\n";
    for (const auto& [key, n] : failed_)
      out << "zoomwarp_http_requests_failed_total{route=\"" << key.first << "\",reason=\"" << key.second << "\"} " << n
          << "\n";
    out << "# HELP zoomwarp_uploads_total Uploads admitted by the rate limits, by key id (\"\": no valid key).\n"
           "# TYPE zoomwarp_uploads_total counter\n";
    for (const auto& [key, n] : uploads_) out << "zoomwarp_uploads_total{key=\"" << escaped(key) << "\"} " << n << "\n";
    out << "# HELP zoomwarp_rate_limited_total Uploads refused with 429, by key id (\"\": no valid key) and limit.\n"
           "# TYPE zoomwarp_rate_limited_total counter\n";
    for (const auto& [key, n] : rate_limited_)
      out << "zoomwarp_rate_limited_total{key=\"" << escaped(key.first) << "\",limit=\"" << key.second << "\"} " << n
          << "\n";
    samplers = samplers_;
  }
  std::string last_name;
  for (const auto& sampler : samplers) {
    for (const Sample& s : sampler()) {
      if (s.name != last_name) {
        out << "# HELP " << s.name << " " << s.help << "\n# TYPE " << s.name << " " << s.type << "\n";
        last_name = s.name;
      }
      out << s.name;
      if (!s.labels.empty()) out << "{" << s.labels << "}";
      if (s.value == std::floor(s.value) && std::fabs(s.value) < 1e15) out << " " << (long long)s.value << "\n";
      else out << " " << s.value << "\n";
    }
  }
  return out.str();
}

}  // namespace zoomwarp::server
