// What `zoomwarp compare` reports of each cell (method × zoom): the label under its picture in
// the contact sheet, its row of metrics.json, and metrics.md made from metrics.json
// (docs/compare.md explains the figures). Plain functions of plain data, called by
// compare_command.cc on its one thread.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "warp/compare/metrics.h"

namespace zoomwarp::server {

// One rendered and measured cell.
struct Cell {
  double zoom = 0;
  warp::ViewMetrics metrics;
  double viewport_ms = 0;  // the rendered screen, first request of the cell (caches as they are)
  warp::SquashMeasures independent;  // against warp/compare/independent_saliency.h's map (issue 41)
};

// Three lines that fit under a 360 px cell: method and zoom with folds and coverage; gain,
// anisotropy and the squash measures under the independent map (salient anisotropy p90/p99, salient
// coverage); rotation (p95 / spread, degrees) and the worst line's bend (px).
std::vector<std::string> cell_label(const std::string& method, const Cell& c);

// The cell's row of metrics.json ("rows"); a figure a method has no value for is null.
nlohmann::json cell_json(const std::string& method, const Cell& c);

// metrics.md: the report's settings, the methods' precompute times and a table row per cell.
std::string report_markdown(const nlohmann::json& report);

}  // namespace zoomwarp::server
