#include "api/mesh_json.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <iterator>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string_view>

#include "warp/core/uniform_zoom.h"

namespace zoomwarp::api {

namespace {

// The body is written as text straight into one string: the vertices, triangles and geomorph
// positions — tens of thousands of numbers — and the tile references by hand, with the values and
// number types nlohmann wrote; the small parts (image, view) as before, as nlohmann trees dumped
// into it. A heap node and a dtoa per number were most of /mesh's cost beyond the warp itself
// (issue 16).

[[noreturn]] void not_finite() {
  // JSON has no NaN or infinity (nlohmann wrote null, which no client can draw and the OpenAPI
  // schema does not allow): a warp that produced one is a bug, answered 500 and logged.
  throw std::runtime_error("mesh JSON: a position or view number is not finite");
}

// For the tree-built parts: a number checked finite (nlohmann would write null), and positions
// to a thousandth of a pixel as write_milli writes them.
double finite(double v) {
  if (!std::isfinite(v)) not_finite();
  return v;
}
double milli(double v) { return finite(std::round(v * 1000) / 1000); }

// The number writers: each writes at `p`, at most kMaxNumber characters, and returns the end.
// A vertex or triangle is formatted into a small buffer and appended at once: appending piece
// by piece cost a fifth of the writer's time.
constexpr std::ptrdiff_t kMaxNumber = 32;

char* write_int(char* p, long long v) { return std::to_chars(p, p + kMaxNumber, v).ptr; }

char* write_text(char* p, std::string_view text) { return std::copy(text.begin(), text.end(), p); }

// The shortest decimal that reads back as `v`, with ".0" on a whole number, as nlohmann writes a
// double (so a parser that tells integers from reals sees a real, as before).
char* write_double(char* p, double v) {
  if (!std::isfinite(v)) not_finite();
  char* end = std::to_chars(p, p + kMaxNumber - 2, v).ptr;
  if (std::none_of(p, end, [](char c) { return c == '.' || c == 'e'; })) *end++ = '.', *end++ = '0';
  return end;
}

// `v` to a thousandth of a pixel (exact enough to draw, half the bytes of full doubles), written
// as fixed point: the value round(v · 1000) / 1000, which a decimal of at most three fraction
// digits names exactly, with the sign of a negative zero kept as nlohmann kept it.
char* write_milli(char* p, double v) {
  const double thousandths = std::round(v * 1000);
  if (!std::isfinite(thousandths)) not_finite();
  if (std::abs(thousandths) >= 0x1p53) return write_double(p, thousandths / 1000);  // not a pixel position
  if (std::signbit(thousandths)) *p++ = '-';
  const auto m = std::uint64_t(std::abs(thousandths));
  p = std::to_chars(p, p + kMaxNumber - 5, m / 1000).ptr;
  const unsigned frac = unsigned(m % 1000);
  p[0] = '.', p[1] = char('0' + frac / 100), p[2] = char('0' + frac / 10 % 10), p[3] = char('0' + frac % 10);
  int digits = 3;
  while (digits > 1 && p[digits] == '0') --digits;
  return p + 1 + digits;
}

// The triangles a client draws, ascending: those touching the screen, in either view of a
// geomorph pair. A plain view has listed them already with the same test (View::visible).
std::vector<int> drawn_triangles(const warp::View& view, const warp::Geomorph* morph, double w, double h) {
  if (!morph) return view.visible;
  const std::vector<int> to = warp::visible_triangles(morph->source, morph->to, w, h);
  const std::vector<int> from = warp::visible_triangles(morph->source, morph->from, w, h);
  std::vector<int> both;
  both.reserve(to.size() + from.size());
  std::set_union(to.begin(), to.end(), from.begin(), from.end(), std::back_inserter(both));
  return both;
}

// The drawn triangles' vertices, numbered compactly in order of first use, and what the tiles
// are chosen by: the source box they cover and the largest on-screen magnification among them.
struct Listing {
  std::vector<int> triangles;  // of the source mesh
  std::vector<int> index;      // per source vertex, its number in the body or -1
  std::vector<int> vertices;   // per listed vertex, its source vertex
  double magnification = 0;
  double u0 = 1e300, v0 = 1e300, u1 = -1e300, v1 = -1e300;
};

Listing list_drawn(const warp::Mesh& source, const std::vector<warp::Point>& screen, std::vector<int> triangles) {
  Listing l;
  l.triangles = std::move(triangles);
  l.index.assign(source.vertices.size(), -1);
  double ratio = 0;  // screen area / source area; its square root is monotone, taken once
  for (int f : l.triangles) {
    const warp::Triangle& t = source.triangles[f];
    for (int v : t)
      if (l.index[v] < 0) l.index[v] = int(l.vertices.size()), l.vertices.push_back(v);
    const double a_src = std::abs(warp::signed_area2(source.vertices[t[0]], source.vertices[t[1]], source.vertices[t[2]]));
    const double a_scr = std::abs(warp::signed_area2(screen[t[0]], screen[t[1]], screen[t[2]]));
    if (a_src > 0) ratio = std::max(ratio, a_scr / a_src);
  }
  l.magnification = std::sqrt(ratio);
  for (int v : l.vertices) {
    const warp::Point& p = source.vertices[v];
    l.u0 = std::min(l.u0, p.x), l.u1 = std::max(l.u1, p.x), l.v0 = std::min(l.v0, p.y), l.v1 = std::max(l.v1, p.y);
  }
  return l;
}

// The Deep Zoom tiles at the level matching the largest magnification that cover the listed
// vertices: [{"col", "level", "row", "url"}, …], keys in nlohmann's (sorted) order. Written as
// text like the rest: a few dozen objects built as a tree cost a heap node per key. No string
// needs escaping: an image id is letters, digits, '-', '_' and '.' (tiles/image_id.h).
void put_tiles(std::string& out, const tiles::Manifest& image, const DziLayout& dzi, const std::string& extension,
               const Listing& l) {
  out += '[';
  if (!l.vertices.empty()) {
    const int level = dzi_level_for(image, l.magnification);
    const std::string prefix = "/dzi/" + image.id + "_files/" + std::to_string(level) + "/";
    bool first = true;
    for (const DziTileRef& t : dzi_tiles_covering(image, dzi, level, l.u0, l.v0, l.u1, l.v1)) {
      char buf[4 * kMaxNumber], *p = buf;
      if (!first) *p++ = ',';
      first = false;
      p = write_text(p, "{\"col\":");
      p = write_int(p, t.col);
      p = write_text(p, ",\"level\":");
      p = write_int(p, t.level);
      p = write_text(p, ",\"row\":");
      p = write_int(p, t.row);
      p = write_text(p, ",\"url\":\"");
      out.append(buf, p).append(prefix);
      p = write_int(buf, t.col);
      *p++ = '_';
      p = write_int(p, t.row);
      *p++ = '.';
      out.append(buf, p).append(extension).append("\"}");
    }
  }
  out += ']';
}

void put_triangles(std::string& out, const warp::Mesh& source, const Listing& l) {
  out += '[';
  for (std::size_t i = 0; i < l.triangles.size(); ++i) {
    const warp::Triangle& t = source.triangles[std::size_t(l.triangles[i])];
    char buf[3 * kMaxNumber + 8], *p = buf;
    if (i) *p++ = ',';
    *p++ = '[';
    p = write_int(p, l.index[std::size_t(t[0])]);
    *p++ = ',';
    p = write_int(p, l.index[std::size_t(t[1])]);
    *p++ = ',';
    p = write_int(p, l.index[std::size_t(t[2])]);
    *p++ = ']';
    out.append(buf, p);
  }
  out += ']';
}

// Per listed vertex, [u, v, x, y] (`source` given) or [x, y].
void put_positions(std::string& out, const std::vector<int>& vertices, const std::vector<warp::Point>* source,
                   const std::vector<warp::Point>& screen) {
  out += '[';
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    const auto v = std::size_t(vertices[i]);
    char buf[4 * kMaxNumber + 8], *p = buf;
    if (i) *p++ = ',';
    *p++ = '[';
    if (source) {
      p = write_milli(p, (*source)[v].x);
      *p++ = ',';
      p = write_milli(p, (*source)[v].y);
      *p++ = ',';
    }
    p = write_milli(p, screen[v].x);
    *p++ = ',';
    p = write_milli(p, screen[v].y);
    *p++ = ']';
    out.append(buf, p);
  }
  out += ']';
}

nlohmann::json view_json(const ViewQuery& q, const warp::View& view) {
  const warp::ZoomGeometry& g = view.geometry;
  nlohmann::json out = {
      {"zoom", finite(q.view.zoom)},
      {"cx", finite(q.view.cx)},
      {"cy", finite(q.view.cy)},
      {"w", q.view.screen_width},
      {"h", q.view.screen_height},
      {"method", std::string(q.method_name())},
      {"curve", q.view.curve == warp::ZoomCurve::kLinear ? "linear" : "geometric"},
      {"fit", std::string(warp::fit_name(q.fit.fit))},
      {"max_distortion", finite(q.fit.max_distortion)},
      {"target", {{"width", milli(g.target_width)}, {"height", milli(g.target_height)}}},
      {"viewing_area",
       {{"x", milli(view.view_x)}, {"y", milli(view.view_y)}, {"width", milli(g.view_width)}, {"height", milli(g.view_height)}}},
      {"scale", finite(g.screen_scale)},
      {"centre_clamped", view.centre_clamped}};
  if (q.from) out["from"] = {{"zoom", finite(q.from->zoom)}, {"cx", finite(q.from->cx)}, {"cy", finite(q.from->cy)}};
  return out;
}

// What the body will take, so that it is allocated once: generous bytes per number.
std::size_t body_estimate(const Listing& l, bool morph) {
  constexpr std::size_t kPerVertex = 4 * 12, kPerFrom = 2 * 12, kPerTriangle = 3 * 7, kTilesAndView = 8192;
  return l.vertices.size() * (kPerVertex + (morph ? kPerFrom : 0)) + l.triangles.size() * kPerTriangle + kTilesAndView;
}

}  // namespace

std::string mesh_json(const tiles::Manifest& image, const ViewQuery& q, const warp::View& view,
                      const warp::Geomorph* morph, const DziLayout& dzi, const std::string& tile_extension) {
  const warp::Mesh& source = morph ? morph->source : view.source;
  const std::vector<warp::Point>& screen = morph ? morph->to : view.screen;
  const Listing l = list_drawn(source, screen, drawn_triangles(view, morph, q.view.screen_width, q.view.screen_height));

  std::string out;
  out.reserve(body_estimate(l, morph));
  // Keys in the order nlohmann's tree wrote them (sorted).
  out += '{';
  if (morph) {
    out += "\"from\":";
    put_positions(out, l.vertices, nullptr, morph->from);
    out += ',';
  }
  out += "\"image\":";
  out += nlohmann::json{{"id", image.id}, {"width", image.width}, {"height", image.height}, {"version", image.version}}.dump();
  out += ",\"tiles\":";
  put_tiles(out, image, dzi, tile_extension, l);
  out += ",\"triangles\":";
  put_triangles(out, source, l);
  out += ",\"vertices\":";
  put_positions(out, l.vertices, &source.vertices, screen);
  out += ",\"view\":";
  out += view_json(q, view).dump();
  out += "}\n";
  return out;
}

}  // namespace zoomwarp::api
