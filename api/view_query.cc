#include "api/view_query.h"

#include <charconv>
#include <cmath>
#include <cstdio>
#include <set>

#include "api/errors.h"
#include "api/url.h"
#include "api/url_signing.h"
#include "warp/core/limits.h"

namespace zoomwarp::api {

namespace {

[[noreturn]] void bad(const std::string& message) { throw ApiError(400, "bad_request", message); }

// A plain decimal, optionally negative (so "-1" is reported as out of range, not as malformed).
double number(const std::string& name, const std::string& text) {
  const bool negative = !text.empty() && text[0] == '-';
  const auto v = parse_plain_decimal(negative ? std::string_view(text).substr(1) : std::string_view(text));
  if (!v) bad(name + " must be a plain decimal number, not '" + text + "'");
  return negative ? -*v : *v;
}

double in_range(const std::string& name, double v, double lo, double hi) {
  if (v < lo || v > hi) {
    char msg[160];
    std::snprintf(msg, sizeof msg, "%s must be in [%g, %g], not %g", name.c_str(), lo, hi, v);
    bad(msg);
  }
  return v;
}

// "icaz, traditional, retarget-zoom, seam, …", for error messages.
std::string method_list() {
  std::string out;
  for (const ViewMethod& m : view_methods()) out += (out.empty() ? "" : ", ") + std::string(m.name());
  return out;
}

int integer(const std::string& name, const std::string& text, int lo, int hi) {
  const double v = number(name, text);
  if (v != std::floor(v)) bad(name + " must be a whole number, not '" + text + "'");
  return int(in_range(name, v, lo, hi));
}

}  // namespace

std::string_view ViewQuery::method_name() const { return method->name(); }

ViewQuery parse_view_query(std::string_view raw_query, ViewRoute route, double W, double H) {
  const auto pairs = parse_query(raw_query);
  if (!pairs) bad("malformed query string");
  ViewQuery q;
  q.view.cx = W / 2, q.view.cy = H / 2;
  bool have_w = false, have_h = false;
  std::optional<double> from_zoom, from_cx, from_cy;
  std::set<std::string> seen;
  for (const auto& [name, value] : *pairs) {
    if (!seen.insert(name).second) bad("parameter " + name + " given twice");
    if (name == "zoom") q.view.zoom = in_range(name, number(name, value), 0, 1);
    else if (name == "cx") q.view.cx = in_range(name, number(name, value), 0, W);
    else if (name == "cy") q.view.cy = in_range(name, number(name, value), 0, H);
    else if (name == "w") q.view.screen_width = integer(name, value, 16, warp::limits::kMaxScreenSide), have_w = true;
    else if (name == "h") q.view.screen_height = integer(name, value, 16, warp::limits::kMaxScreenSide), have_h = true;
    else if (name == "method") {
      q.method = find_view_method(value);
      if (!q.method) bad("method must be one of " + method_list() + ", not '" + value + "'");
    } else if (name == "saliency") {
      const auto s = warp::parse_saliency(value);
      if (!s) bad("saliency must be default or gbvs, not '" + value + "'");
      q.saliency = *s;
    } else if (name == "lines") {
      const auto lines = warp::parse_line_set(value);
      if (!lines) bad("lines must be auto, curator or none, not '" + value + "'");
      q.lines = *lines;
    } else if (name == "curve") {
      if (value == "geometric") q.view.curve = warp::ZoomCurve::kGeometric;
      else if (value == "linear") q.view.curve = warp::ZoomCurve::kLinear;
      else bad("curve must be geometric or linear, not '" + value + "'");
    } else if (name == "fit") {
      const auto fit = warp::parse_fit(value);
      if (!fit) bad("fit must be auto, warp, crop or pad, not '" + value + "'");
      q.fit.fit = *fit;
    } else if (name == "max_distortion") {
      q.fit.max_distortion = in_range(name, number(name, value), warp::kMinMaxDistortion, warp::kMaxMaxDistortion);
    } else if (route == ViewRoute::kMesh && name == "from_zoom") from_zoom = in_range(name, number(name, value), 0, 1);
    else if (route == ViewRoute::kMesh && name == "from_cx") from_cx = in_range(name, number(name, value), 0, W);
    else if (route == ViewRoute::kMesh && name == "from_cy") from_cy = in_range(name, number(name, value), 0, H);
    else if (route == ViewRoute::kViewport && name == "format") {
      const auto f = tiles::format_from_extension(value);
      if (!f) bad("format must be jpg, png, webp, avif or jxl, not '" + value + "'");
      q.format = *f;
    } else if (route == ViewRoute::kViewport && name == "quality") q.quality = integer(name, value, 1, 100);
    else if (is_signature_parameter(name)) continue;  // the router checks them; they name no view
    else bad("unknown parameter '" + name + "'");
  }
  if (!have_w || !have_h)
    bad("w and h (screen size in pixels, 16…" + std::to_string(warp::limits::kMaxScreenSide) + ") are required");
  if ((long long)q.view.screen_width * q.view.screen_height > warp::limits::kMaxScreenPixels)
    bad("the screen (w × h) has at most " + std::to_string(warp::limits::kMaxScreenPixels) + " pixels");
  // A method that takes no lines shows the same view for each line set: one cache entry, one engine.
  if (!q.method->takes_lines()) q.lines = warp::LineSet::kCurator;
  if (from_zoom || from_cx || from_cy) {
    q.from = q.view;
    if (from_zoom) q.from->zoom = *from_zoom;
    if (from_cx) q.from->cx = *from_cx;
    if (from_cy) q.from->cy = *from_cy;
  }
  return q;
}

namespace {
// `v` as printf's %.17g writes it (std::to_chars with a precision is defined as that printf
// conversion), without printf's format parsing: the key is made twice for every view request.
void append_g17(std::string& out, double v) {
  char buf[32];
  out.append(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::general, 17).ptr);
}
}  // namespace

std::string ViewQuery::canonical() const {
  std::string out;
  out.reserve(160);
  out.append(method_name()).append("|").append(warp::saliency_name(saliency)).append("|");
  out.append(warp::line_set_name(lines)).append("|");
  out.append(view.curve == warp::ZoomCurve::kLinear ? "linear" : "geometric").append("|z=");
  append_g17(out, view.zoom);
  out.append("|c=");
  append_g17(out, view.cx);
  out.append(",");
  append_g17(out, view.cy);
  out.append("|s=").append(std::to_string(view.screen_width)).append("x").append(std::to_string(view.screen_height));
  // fit=warp draws what every view drew before fit= (issue 41): its key is the key of then, so an
  // ETag from then still revalidates; the other fits draw other views and have keys of their own.
  if (fit.fit != warp::Fit::kWarp) {
    out.append("|fit=").append(warp::fit_name(fit.fit));
    if (fit.fit == warp::Fit::kAuto) {
      out.append(",");
      append_g17(out, fit.max_distortion);
    }
  }
  if (from) {
    out.append("|from=");
    append_g17(out, from->zoom);
    out.append(",");
    append_g17(out, from->cx);
    out.append(",");
    append_g17(out, from->cy);
  }
  out += "|" + std::string(tiles::extension(format)) + "|q=" + std::to_string(quality);
  return out;
}

}  // namespace zoomwarp::api
