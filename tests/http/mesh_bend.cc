#include "tests/http/mesh_bend.h"

#include <algorithm>

#include "warp/compare/metrics.h"

namespace zoomwarp::testing {

MeshLineBend worst_line_bend(const nlohmann::json& mesh, const nlohmann::json& lines) {
  warp::View view;
  for (const nlohmann::json& v : mesh["vertices"]) {
    view.source.vertices.push_back({v[0], v[1]});
    view.screen.push_back({v[2], v[3]});
  }
  for (const nlohmann::json& t : mesh["triangles"]) {
    view.visible.push_back(int(view.source.triangles.size()));
    view.source.triangles.push_back({t[0].get<int>(), t[1].get<int>(), t[2].get<int>()});
  }
  const int w = mesh["view"]["w"], h = mesh["view"]["h"];
  MeshLineBend out;
  for (const char* set : {"lines", "suggested"})
    for (const nlohmann::json& s : lines[set]) {
      const auto bend = warp::line_bend(view, {{s[0], s[1]}, {s[2], s[3]}}, w, h);
      if (!bend || bend->chord < warp::kMinMeasuredLinePx) continue;
      ++out.measured;
      out.worst_px = std::max(out.worst_px, bend->deviation);
    }
  return out;
}

}  // namespace zoomwarp::testing
