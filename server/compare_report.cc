#include "server/compare_report.h"

#include <cstdio>
#include <optional>
#include <sstream>

namespace zoomwarp::server {

using nlohmann::json;

namespace {

json optional_json(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

std::string text(const std::optional<double>& v, const char* format = "%.2f") {
  if (!v) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, *v);
  return buf;
}

}  // namespace

std::vector<std::string> cell_label(const std::string& method, const Cell& c) {
  const warp::ViewMetrics& m = c.metrics;
  char line[128];
  std::snprintf(line, sizeof line, "%s  z=%.2f  folds %s  cover %.3f", method.c_str(), c.zoom,
                m.folds ? std::to_string(*m.folds).c_str() : "n/a", m.coverage);
  std::vector<std::string> out = {line};
  std::snprintf(line, sizeof line, "gain %s aniso %s  ind %s/%s cov %s", text(m.scale_gain).c_str(),
                text(m.anisotropy_salient).c_str(), text(c.independent.anisotropy_p90).c_str(),
                text(c.independent.anisotropy_p99).c_str(), text(c.independent.coverage).c_str());
  out.push_back(line);
  std::snprintf(line, sizeof line, "rot %s/%s deg  line %s px", text(m.rotation_p95, "%.1f").c_str(),
                text(m.rotation_spread, "%.1f").c_str(), text(m.straightness, "%.1f").c_str());
  out.push_back(line);
  return out;
}

json cell_json(const std::string& method, const Cell& c) {
  const warp::ViewMetrics& m = c.metrics;
  return {{"method", method},
          {"zoom", c.zoom},
          {"scale_gain", optional_json(m.scale_gain)},
          {"anisotropy_salient", optional_json(m.anisotropy_salient)},
          {"anisotropy_weighted", optional_json(m.anisotropy_weighted)},
          {"rotation_p95", optional_json(m.rotation_p95)},
          {"rotation_spread", optional_json(m.rotation_spread)},
          {"line_px", optional_json(m.straightness)},
          {"lines_measured", m.lines_measured ? json(*m.lines_measured) : json(nullptr)},
          {"folds", m.folds ? json(*m.folds) : json(nullptr)},
          {"coverage", m.coverage},
          {"salient_p90", optional_json(m.squash.anisotropy_p90)},
          {"salient_p99", optional_json(m.squash.anisotropy_p99)},
          {"salient_coverage", optional_json(m.squash.coverage)},
          {"independent_p90", optional_json(c.independent.anisotropy_p90)},
          {"independent_p99", optional_json(c.independent.anisotropy_p99)},
          {"independent_coverage", optional_json(c.independent.coverage)},
          {"viewport_ms", c.viewport_ms}};
}

std::string report_markdown(const json& report) {
  std::ostringstream md;
  md << "# zoomwarp compare: " << report["image"].get<std::string>() << "\n\n"
     << "Image " << report["width"] << "×" << report["height"] << ", screen " << report["screen"][0] << "×"
     << report["screen"][1] << ", saliency " << report["saliency"].get<std::string>() << ", lines "
     << report["lines"].get<std::string>()
     << ", view centre the image centre. Gain: on-screen area of the top tenth of the significance map over its area "
        "under traditional zoom; anisotropy: σ1/σ2 of the triangles' affine maps, salient-area and "
        "significance weighted; rot. p95: 95th percentile of the triangles' rotation (degrees, polar "
        "decomposition) over the salient region's on-screen area; rot. spread: its significance-weighted standard "
        "deviation (what bends shapes); line px: the worst line's distance from its chord on screen, over the "
        "curator's and the detected lines not dismissed whose chord on screen is at least 8 px (lines: how many); "
        "viewport ms: the cell's first render (caches warm from the cells before it). Squash (issue 41), under the "
        "server's map and under an independent one (spectral residual on a 128-px thumbnail): the 90th and 99th "
        "percentile of σ1/σ2 over the top fifth of the map's pixels that land on the screen, and the share of their "
        "mass that does (coverage).\n\n"
     << "| method | precompute ms |\n|---|---|\n";
  for (const auto& m : report["methods"]) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", m["precompute_ms"].get<double>());
    md << "| " << m["name"].get<std::string>() << " | " << buf << " |\n";
  }
  md << "\n| method | fit | zoom | gain | aniso. salient | aniso. weighted | rot. p95 | rot. spread | line px | lines | folds "
        "| coverage | squash p90 / p99 / cov. | independent p90 / p99 / cov. | viewport ms |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto cell = [](const json& v, const char* format = "%.2f") {
    if (v.is_null()) return std::string("n/a");
    char buf[32];
    std::snprintf(buf, sizeof buf, format, v.get<double>());
    return std::string(buf);
  };
  auto count = [](const json& v) { return v.is_null() ? std::string("n/a") : std::to_string(v.get<int>()); };
  for (const auto& r : report["rows"])
    md << "| " << r["method"].get<std::string>() << " | " << (r.contains("fit") ? r["fit"].get<std::string>() : "") << " | "
       << cell(r["zoom"]) << " | " << cell(r["scale_gain"]) << " | "
       << cell(r["anisotropy_salient"]) << " | " << cell(r["anisotropy_weighted"]) << " | "
       << cell(r["rotation_p95"], "%.1f") << " | " << cell(r["rotation_spread"], "%.1f") << " | " << cell(r["line_px"])
       << " | " << count(r["lines_measured"]) << " | " << count(r["folds"]) << " | " << cell(r["coverage"], "%.4f")
       << " | " << cell(r["salient_p90"]) << " / " << cell(r["salient_p99"]) << " / " << cell(r["salient_coverage"])
       << " | " << cell(r["independent_p90"]) << " / " << cell(r["independent_p99"]) << " / "
       << cell(r["independent_coverage"]) << " | " << cell(r["viewport_ms"], "%.1f") << " |\n";
  return md.str();
}

}  // namespace zoomwarp::server
