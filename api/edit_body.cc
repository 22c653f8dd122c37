#include "api/edit_body.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "warp/core/limits.h"

namespace zoomwarp::api {

namespace {

using nlohmann::json;

[[noreturn]] void bad_body(const std::string& message) { throw ApiError(400, "invalid_body", message); }

// Over a limit of warp/core/limits.h: 413, whose code names the limit (README "Limits").
[[noreturn]] void over_limit(const std::string& code, const std::string& message) { throw ApiError(413, code, message); }

// Checked before the items are parsed, so an oversized array costs no more than its JSON parse.
void at_most(std::size_t n, long long limit, const char* code, const std::string& what) {
  if (n > std::size_t(limit)) over_limit(code, "at most " + std::to_string(limit) + " " + what + ", not " + std::to_string(n));
}

// A finite number inside [lo, hi] from a JSON value.
double coordinate(const json& j, double lo, double hi, const char* what) {
  if (!j.is_number()) bad_body(std::string(what) + " must be numbers");
  const double v = j.get<double>();
  if (!std::isfinite(v) || v < lo || v > hi) bad_body(what + std::string(" must lie inside the image"));
  return v;
}

// [[x0, y0, x1, y1], …] inside the image, at most limits::kMaxLines of them.
std::vector<warp::Segment> segments(const json& array, double W, double H, const char* what) {
  at_most(array.size(), warp::limits::kMaxLines, "too_many_lines", what);
  std::vector<warp::Segment> out;
  for (const json& l : array) {
    if (!l.is_array() || l.size() != 4) bad_body(std::string("each of the ") + what + " is [x0, y0, x1, y1]");
    out.push_back({{coordinate(l[0], 0, W, "line ends"), coordinate(l[1], 0, H, "line ends")},
                   {coordinate(l[2], 0, W, "line ends"), coordinate(l[3], 0, H, "line ends")}});
  }
  return out;
}

warp::ModelEdit lines_edit(const json& body, double W, double H) {
  const bool has_dismissed = body.is_object() && body.contains("dismissed");
  if (!body.is_object() || !body.contains("lines") || !body["lines"].is_array() ||
      body.size() != (has_dismissed ? 2u : 1u) || (has_dismissed && !body["dismissed"].is_array()))
    bad_body(R"(expected {"lines": [[x0, y0, x1, y1], …]} and optionally "dismissed": [[x0, y0, x1, y1], …])");
  std::vector<warp::Segment> lines = segments(body["lines"], W, H, "lines");
  double total = 0;
  for (const warp::Segment& l : lines) total += std::hypot(l.b.x - l.a.x, l.b.y - l.a.y);
  // [ICAZ §4.3] Every line adds its chain of mesh vertices to the coarsest mesh and its energy
  // terms to every solve: the summed length bounds that cost.
  const double max_total = warp::limits::kMaxTotalLineLength * std::max(W, H);
  if (total > max_total) {
    char msg[160];
    std::snprintf(msg, sizeof msg, "the lines' total length is at most %g × the image's larger side (%g px), not %g px",
                  warp::limits::kMaxTotalLineLength, max_total, total);
    over_limit("lines_too_long", msg);
  }
  warp::ModelEdit edit;
  edit.lines = std::move(lines);
  // Suggested lines the curator dropped (warp/analysis/detected_lines.h); absent: unchanged.
  if (has_dismissed) edit.dismissed_lines = segments(body["dismissed"], W, H, "dismissed lines");
  return edit;
}

warp::ModelEdit significance_edit(const json& body, double W, double H) {
  if (!body.is_object() || !body.contains("regions") || !body["regions"].is_array() || body.size() != 1 ||
      body["regions"].empty())
    bad_body(R"(expected {"regions": [{"rect": [x, y, w, h], "weight": s} or {"polygon": [[x, y], …], "weight": s}, …]})");
  at_most(body["regions"].size(), warp::limits::kMaxRegionsPerEdit, "too_many_regions", "regions per edit");
  warp::ModelEdit edit;
  for (const json& r : body["regions"]) {
    if (!r.is_object() || !r.contains("weight") || r.size() != 2 || (!r.contains("rect") && !r.contains("polygon")))
      bad_body("each region has a weight and either a rect or a polygon");
    if (!r["weight"].is_number()) bad_body("weight must be a number in [0, 1]");
    const double weight = r["weight"].get<double>();
    if (!(weight >= 0 && weight <= 1)) bad_body("weight must be in [0, 1]");
    warp::SignificanceEdit e;
    e.weight = float(weight);
    if (r.contains("rect")) {
      const json& rect = r["rect"];
      if (!rect.is_array() || rect.size() != 4) bad_body("rect is [x, y, w, h]");
      const double x = coordinate(rect[0], 0, W, "rect"), y = coordinate(rect[1], 0, H, "rect");
      const double w = coordinate(rect[2], 0, W - x, "rect"), h = coordinate(rect[3], 0, H - y, "rect");
      if (!(w > 0 && h > 0)) bad_body("rect needs a positive width and height");
      e.polygon = {{x, y}, {x + w, y}, {x + w, y + h}, {x, y + h}};
    } else {
      const json& polygon = r["polygon"];
      if (!polygon.is_array() || polygon.size() < 3) bad_body("a polygon needs at least 3 points");
      at_most(polygon.size(), warp::limits::kMaxPolygonPoints, "too_many_points", "points per polygon");
      for (const json& p : polygon) {
        if (!p.is_array() || p.size() != 2) bad_body("polygon points are [x, y]");
        e.polygon.push_back({coordinate(p[0], 0, W, "polygon points"), coordinate(p[1], 0, H, "polygon points")});
      }
    }
    edit.significance.push_back(std::move(e));
  }
  return edit;
}

json parse(std::string_view body) {
  try {
    return json::parse(body);
  } catch (const json::exception&) {
    bad_body("the body is not valid JSON");
  }
}

}  // namespace

warp::ModelEdit parse_lines_body(std::string_view body, double W, double H) { return lines_edit(parse(body), W, H); }

warp::ModelEdit parse_significance_body(std::string_view body, double W, double H) {
  return significance_edit(parse(body), W, H);
}

}  // namespace zoomwarp::api
