#include "tests/support/mesh_json_reference.h"

#include <cmath>
#include <nlohmann/json.hpp>

namespace zoomwarp::testing {

using api::DziLayout;
using api::DziTileRef;
using api::ViewQuery;

namespace {

using nlohmann::json;

// Positions to a thousandth of a pixel: exact enough to draw, half the bytes of full doubles.
double milli(double v) { return std::round(v * 1000) / 1000; }

bool touches_screen(const std::vector<warp::Point>& p, const warp::Triangle& t, double w, double h) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (int v : t) x0 = std::min(x0, p[v].x), x1 = std::max(x1, p[v].x), y0 = std::min(y0, p[v].y), y1 = std::max(y1, p[v].y);
  return x1 > 0 && x0 < w && y1 > 0 && y0 < h;
}

}  // namespace

std::string reference_mesh_json(const tiles::Manifest& image, const ViewQuery& q, const warp::View& view,
                                const warp::Geomorph* morph, const DziLayout& dzi, const std::string& tile_extension) {
  const warp::Mesh& source = morph ? morph->source : view.source;
  const std::vector<warp::Point>& screen = morph ? morph->to : view.screen;
  const double w = q.view.screen_width, h = q.view.screen_height;

  // The listed triangles: those touching the screen (in either view of a geomorph pair), with
  // their vertices renumbered compactly.
  std::vector<int> index(source.vertices.size(), -1), vertices;
  json triangles = json::array();
  double magnification = 0, u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
  for (const warp::Triangle& t : source.triangles) {
    if (!touches_screen(screen, t, w, h) && !(morph && touches_screen(morph->from, t, w, h))) continue;
    json tri = json::array();
    for (int v : t) {
      if (index[v] < 0) index[v] = int(vertices.size()), vertices.push_back(v);
      tri.push_back(index[v]);
      u0 = std::min(u0, source.vertices[v].x), u1 = std::max(u1, source.vertices[v].x);
      v0 = std::min(v0, source.vertices[v].y), v1 = std::max(v1, source.vertices[v].y);
    }
    triangles.push_back(std::move(tri));
    const double a_src = std::abs(warp::signed_area2(source.vertices[t[0]], source.vertices[t[1]], source.vertices[t[2]]));
    const double a_scr = std::abs(warp::signed_area2(screen[t[0]], screen[t[1]], screen[t[2]]));
    if (a_src > 0) magnification = std::max(magnification, std::sqrt(a_scr / a_src));
  }
  json verts = json::array(), from = json::array();
  for (int v : vertices) {
    verts.push_back({milli(source.vertices[v].x), milli(source.vertices[v].y), milli(screen[v].x), milli(screen[v].y)});
    if (morph) from.push_back({milli(morph->from[v].x), milli(morph->from[v].y)});
  }
  json tiles = json::array();
  if (!vertices.empty()) {
    const int level = api::dzi_level_for(image, magnification);
    for (const DziTileRef& t : api::dzi_tiles_covering(image, dzi, level, u0, v0, u1, v1))
      tiles.push_back({{"level", t.level}, {"col", t.col}, {"row", t.row},
                       {"url", "/dzi/" + image.id + "_files/" + std::to_string(t.level) + "/" + std::to_string(t.col) +
                                   "_" + std::to_string(t.row) + "." + tile_extension}});
  }
  const warp::ZoomGeometry& g = view.geometry;
  json view_json = {{"zoom", q.view.zoom},
                    {"cx", q.view.cx},
                    {"cy", q.view.cy},
                    {"w", q.view.screen_width},
                    {"h", q.view.screen_height},
                    {"method", std::string(q.method_name())},
                    {"curve", q.view.curve == warp::ZoomCurve::kLinear ? "linear" : "geometric"},
                    {"fit", std::string(warp::fit_name(q.fit.fit))},
                    {"max_distortion", q.fit.max_distortion},
                    {"target", {{"width", milli(g.target_width)}, {"height", milli(g.target_height)}}},
                    {"viewing_area",
                     {{"x", milli(view.view_x)}, {"y", milli(view.view_y)}, {"width", milli(g.view_width)}, {"height", milli(g.view_height)}}},
                    {"scale", g.screen_scale},
                    {"centre_clamped", view.centre_clamped}};
  if (q.from) view_json["from"] = {{"zoom", q.from->zoom}, {"cx", q.from->cx}, {"cy", q.from->cy}};
  json body = {{"image", {{"id", image.id}, {"width", image.width}, {"height", image.height}, {"version", image.version}}},
               {"view", view_json},
               {"vertices", verts},
               {"triangles", triangles},
               {"tiles", tiles}};
  if (morph) body["from"] = from;
  return body.dump() + "\n";
}

}  // namespace zoomwarp::testing
