#include "api/route_match.h"

#include <algorithm>
#include <stdexcept>

#include "api/url.h"

namespace zoomwarp::api {

namespace {

// Matches one decoded path segment against a template segment, appending its parameters as
// match_path() says.
bool match_segment(std::string_view tmpl, std::string_view seg, PathParams& params) {
  std::size_t t = 0, pos = 0;
  while (t < tmpl.size()) {
    if (tmpl[t] != '{') {
      const std::size_t lit_end = std::min(tmpl.find('{', t), tmpl.size());
      const std::string_view lit = tmpl.substr(t, lit_end - t);
      if (seg.substr(pos, lit.size()) != lit) return false;
      pos += lit.size(), t = lit_end;
      continue;
    }
    const std::size_t close = tmpl.find('}', t);
    const std::string_view name = tmpl.substr(t + 1, close - t - 1);
    t = close + 1;
    std::size_t value_end = seg.size();
    if (t < tmpl.size()) {
      const std::size_t lit_end = std::min(tmpl.find('{', t), tmpl.size());
      const std::string_view lit = tmpl.substr(t, lit_end - t);
      const bool last_literal = tmpl.find('{', lit_end) == std::string_view::npos;
      value_end = last_literal ? seg.rfind(lit) : seg.find(lit, pos + 1);
      if (value_end == std::string_view::npos || value_end <= pos) return false;
    }
    if (value_end <= pos) return false;
    params.emplace_back(name, std::string(seg.substr(pos, value_end - pos)));
    pos = value_end;
  }
  return pos == seg.size();
}

}  // namespace

std::optional<std::vector<std::string>> route_segments(std::string_view path) {
  auto segments = split_path(path);
  if (segments && segments->size() > 1 && segments->back().empty()) segments->pop_back();
  return segments;
}

bool match_path(std::string_view tmpl, const std::vector<std::string>& segments, PathParams& params) {
  params.clear();
  std::size_t i = 0, t = 1;  // both start with '/'
  while (t <= tmpl.size()) {
    const std::size_t end = std::min(tmpl.find('/', t), tmpl.size());
    if (i >= segments.size() || !match_segment(tmpl.substr(t, end - t), segments[i], params)) return false;
    ++i, t = end + 1;
  }
  return i == segments.size();
}

const std::string& param(const PathParams& params, std::string_view name) {
  for (const auto& [k, v] : params)
    if (k == name) return v;
  throw std::logic_error("route parameter missing from the template");
}

}  // namespace zoomwarp::api
