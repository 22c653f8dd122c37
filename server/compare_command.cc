// `zoomwarp compare IMAGE --methods … --size WxH --zoom … -o DIR`: one comparison bench for every
// retargeting method (docs/compare.md). Each cell (method × zoom) is rendered by the code
// /viewport runs (api::WarpEngines' engines, warp::render_view / Retargeter::render) and measured
// by warp/compare/metrics.h against traditional zoom at the same view; the results are
// DIR/sheet.png (warp/compare/contact_sheet.h), DIR/metrics.json and DIR/metrics.md.
//
// Exit codes: 0 done, 2 usage (bad arguments, unknown method), 1 anything else.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <tuple>

#include "api/warp_engines.h"
#include "server/commands.h"
#include "server/settings.h"
#include "tiles/encode.h"
#include "tiles/ingest.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/line_set.h"
#include "warp/analysis/method_files.h"
#include "warp/compare/contact_sheet.h"
#include "warp/compare/metrics.h"
#include "warp/core/limits.h"
#include "warp/render/render.h"

namespace zoomwarp::server {

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr std::size_t kMaxZooms = 16;

// The methods `--methods` may name: ICAZ and traditional zoom (the ICAZ operator's), then every
// registered one.
std::vector<std::string> known_methods() {
  std::vector<std::string> out = {"icaz", "traditional"};
  for (const warp::RetargetingMethod* m : warp::retargeting_methods()) out.emplace_back(m->name);
  return out;
}

std::string joined(const std::vector<std::string>& names) {
  std::string out;
  for (const auto& n : names) out += (out.empty() ? "" : ", ") + n;
  return out;
}

std::vector<std::string> split(const std::string& text, char sep) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, sep);) out.push_back(item);
  return out;
}

std::vector<std::string> parse_methods(const std::string& text) {
  const std::vector<std::string> known = known_methods();
  if (text == "all") return known;
  std::vector<std::string> out;
  for (const std::string& name : split(text, ',')) {
    if (std::find(known.begin(), known.end(), name) == known.end())
      throw std::invalid_argument("unknown method '" + name + "'; known: " + joined(known) + " (or all)");
    if (std::find(out.begin(), out.end(), name) != out.end()) throw std::invalid_argument("method '" + name + "' given twice");
    out.push_back(name);
  }
  if (out.empty()) throw std::invalid_argument("--methods names no method");
  return out;
}

// "360x640": both sides 16…kMaxScreenSide, at most kMaxScreenPixels, as /viewport allows.
std::pair<int, int> parse_size(const std::string& text) {
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%dx%d%c", &w, &h, &tail) != 2)
    throw std::invalid_argument("--size must be WIDTHxHEIGHT, e.g. 360x640, not '" + text + "'");
  const int max = warp::limits::kMaxScreenSide;
  if (w < 16 || h < 16 || w > max || h > max || (long long)w * h > warp::limits::kMaxScreenPixels)
    throw std::invalid_argument("--size: each side 16…" + std::to_string(max) + ", at most " +
                                std::to_string(warp::limits::kMaxScreenPixels) + " pixels, not '" + text + "'");
  return {w, h};
}

std::vector<double> parse_zooms(const std::string& text) {
  std::vector<double> out;
  for (const std::string& item : split(text, ',')) {
    char* end = nullptr;
    const double z = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != 0 || !std::isfinite(z) || z < 0 || z > 1)
      throw std::invalid_argument("--zoom takes numbers in [0, 1] separated by commas, not '" + item + "'");
    out.push_back(z);
  }
  if (out.empty() || out.size() > kMaxZooms)
    throw std::invalid_argument("--zoom takes 1…" + std::to_string(kMaxZooms) + " zoom levels");
  return out;
}

// A temporary store for an IMAGE given as a file, removed when done.
class TemporaryStore {
 public:
  TemporaryStore() {
    std::string pattern = (std::filesystem::temp_directory_path() / "zoomwarp-compare-XXXXXX").string();
    if (!::mkdtemp(pattern.data())) throw std::runtime_error("cannot make a temporary folder in " + pattern);
    path_ = pattern;
  }
  ~TemporaryStore() {
    std::error_code ignored;
    std::filesystem::remove_all(path_, ignored);
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
};

// One method as the comparison sees it: its view (for the metrics) and its screen (as /viewport
// renders it).
struct Contender {
  std::string name;
  bool has_mesh = true;
  double precompute_ms = 0;  // the engine's first load: model files read, method loaded
  std::function<warp::View(const warp::ViewRequest&)> view;
  std::function<tiles::Raster(const warp::ViewRequest&)> render;
  // Without a mesh: what each screen pixel shows (Retargeter::screen_sources).
  std::function<std::vector<warp::Point>(const warp::ViewRequest&)> screen_sources;
};

struct Cell {
  double zoom = 0;
  warp::ViewMetrics metrics;
  double viewport_ms = 0;  // the rendered screen, first request of the cell (caches as they are)
};

json optional_json(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

std::string text(const std::optional<double>& v, const char* format = "%.2f") {
  if (!v) return "n/a";
  char buf[32];
  std::snprintf(buf, sizeof buf, format, *v);
  return buf;
}

// Three lines that fit under a 360 px cell: method and zoom with folds and coverage; gain and
// anisotropy; rotation (p95 / spread, degrees) and the worst line's bend (px).
std::vector<std::string> label(const std::string& method, const Cell& c) {
  const warp::ViewMetrics& m = c.metrics;
  char line[128];
  std::snprintf(line, sizeof line, "%s  z=%.2f  folds %s  cover %.3f", method.c_str(), c.zoom,
                m.folds ? std::to_string(*m.folds).c_str() : "n/a", m.coverage);
  std::vector<std::string> out = {line};
  std::snprintf(line, sizeof line, "gain %s  aniso %s", text(m.scale_gain).c_str(), text(m.anisotropy_salient).c_str());
  out.push_back(line);
  std::snprintf(line, sizeof line, "rot %s/%s deg  line %s px", text(m.rotation_p95, "%.1f").c_str(),
                text(m.rotation_spread, "%.1f").c_str(), text(m.straightness, "%.1f").c_str());
  out.push_back(line);
  return out;
}

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out.flush()) throw std::runtime_error("cannot write " + path.string());
}

std::string markdown(const json& report) {
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
        "viewport ms: the cell's first render (caches warm from the cells before it).\n\n"
     << "| method | precompute ms |\n|---|---|\n";
  for (const auto& m : report["methods"]) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.1f", m["precompute_ms"].get<double>());
    md << "| " << m["name"].get<std::string>() << " | " << buf << " |\n";
  }
  md << "\n| method | zoom | gain | aniso. salient | aniso. weighted | rot. p95 | rot. spread | line px | lines | folds "
        "| coverage | viewport ms |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto cell = [](const json& v, const char* format = "%.2f") {
    if (v.is_null()) return std::string("n/a");
    char buf[32];
    std::snprintf(buf, sizeof buf, format, v.get<double>());
    return std::string(buf);
  };
  auto count = [](const json& v) { return v.is_null() ? std::string("n/a") : std::to_string(v.get<int>()); };
  for (const auto& r : report["rows"])
    md << "| " << r["method"].get<std::string>() << " | " << cell(r["zoom"]) << " | " << cell(r["scale_gain"]) << " | "
       << cell(r["anisotropy_salient"]) << " | " << cell(r["anisotropy_weighted"]) << " | "
       << cell(r["rotation_p95"], "%.1f") << " | " << cell(r["rotation_spread"], "%.1f") << " | " << cell(r["line_px"])
       << " | " << count(r["lines_measured"]) << " | " << count(r["folds"]) << " | " << cell(r["coverage"], "%.4f")
       << " | " << cell(r["viewport_ms"], "%.1f") << " |\n";
  return md.str();
}

constexpr const char* kHelp =
    "usage: zoomwarp compare IMAGE [OPTIONS] -o DIR\n"
    "       zoomwarp compare --store S --image ID [OPTIONS] -o DIR\n\n"
    "Renders IMAGE (a file, ingested into a temporary store; or image ID of store S) with each\n"
    "method at each zoom on one screen, as /viewport does, and writes DIR/sheet.png (a row per\n"
    "method, a column per zoom, labelled), DIR/metrics.json and DIR/metrics.md: salient-region\n"
    "scale gain over traditional zoom, anisotropy, rotation (95th percentile over the salient\n"
    "region, and its spread: what bends shapes), line bend (the worst of the curator's and the\n"
    "detected lines not dismissed, each at least 8 px long on screen, and how many were measured),\n"
    "fold-overs, screen coverage, time per request, precompute time. Exit codes: 0 done, 2 bad\n"
    "arguments, 1 anything else.\n\n";

// What the command line asks for, checked (std::invalid_argument says what is wrong).
struct Settings {
  std::vector<std::string> methods;
  int screen_width = 0, screen_height = 0;
  std::vector<double> zooms;
  warp::Saliency saliency = warp::Saliency::kDefault;
  warp::LineSet lines = warp::LineSet::kAuto;
  std::filesystem::path out;
  std::string file;      // an IMAGE file, or
  std::string image_id;  // an image of --store
};

Settings parse_settings(const Options& o) {
  Settings s;
  s.methods = parse_methods(o.str("methods"));
  std::tie(s.screen_width, s.screen_height) = parse_size(o.str("size"));
  s.zooms = parse_zooms(o.str("zoom"));
  const auto saliency = warp::parse_saliency(o.str("saliency"));
  if (!saliency) throw std::invalid_argument("--saliency must be default or gbvs, not '" + o.str("saliency") + "'");
  s.saliency = *saliency;
  const auto lines = warp::parse_line_set(o.str("lines"));
  if (!lines) throw std::invalid_argument("--lines must be auto, curator or none, not '" + o.str("lines") + "'");
  s.lines = *lines;
  s.out = o.str("out");
  if (s.out.empty()) throw std::invalid_argument("give the output folder with -o DIR");
  s.image_id = o.str("image");
  if (o.positionals().size() > 1 || o.positionals().empty() == s.image_id.empty())
    throw std::invalid_argument("give either one IMAGE file or --store S --image ID (see --help)");
  if (!o.positionals().empty()) {
    s.file = o.positionals()[0];
    if (!std::filesystem::is_regular_file(s.file)) throw std::invalid_argument("no such file: " + s.file);
  }
  return s;
}

// The engines of the methods compared, each timed on its first load. ICAZ and traditional zoom
// share one engine for the default saliency: its load (model files read, coarsest mesh factored)
// counts as the precomputation of both.
std::vector<Contender> make_contenders(const Settings& s, api::WarpEngines& engines, const tiles::ImageEntry& e,
                                       tiles::PyramidReader& reader, const std::shared_ptr<warp::Icaz>& plain,
                                       double plain_load_ms) {
  std::vector<Contender> out;
  for (const std::string& name : s.methods) {
    Contender c;
    c.name = name;
    const auto t0 = Clock::now();
    if (name == "icaz" || name == "traditional") {
      const bool own = name == "icaz" && s.saliency != warp::Saliency::kDefault;
      const std::shared_ptr<warp::Icaz> icaz = own ? engines.get(e, s.saliency, s.lines) : plain;
      if (!own) c.precompute_ms = plain_load_ms;
      c.view = name == "icaz" ? std::function([icaz](const warp::ViewRequest& r) { return icaz->view(r); })
                              : std::function([icaz](const warp::ViewRequest& r) { return icaz->traditional(r); });
      c.render = [&e, &reader, view = c.view](const warp::ViewRequest& r) {
        return warp::render_view(view(r), r.screen_width, r.screen_height, e, reader);
      };
    } else {
      const std::shared_ptr<warp::Retargeter> engine =
          engines.retargeter(e, *warp::find_retargeting_method(name), s.saliency, s.lines);
      c.has_mesh = engine->has_mesh();
      c.view = [engine](const warp::ViewRequest& r) { return engine->view(r); };
      c.render = [&e, &reader, engine](const warp::ViewRequest& r) { return engine->render(r, e, reader); };
      c.screen_sources = [engine](const warp::ViewRequest& r) { return engine->screen_sources(r); };
    }
    c.precompute_ms += ms_since(t0);
    out.push_back(std::move(c));
  }
  return out;
}

json row_json(const std::string& method, const Cell& c) {
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
          {"viewport_ms", c.viewport_ms}};
}

// Renders and measures every cell of image `e`; fills `report` and returns the sheet's cells.
std::vector<std::vector<warp::SheetCell>> run(const Settings& s, const tiles::ImageEntry& e, tiles::PyramidReader& reader,
                                              const warp::SignificanceOptions& significance, json& report) {
  api::WarpEngines engines(reader, {.budget_bytes = std::size_t(4) << 30, .significance = significance});
  // The reference (traditional zoom), and the map that defines the salient region.
  const auto t0 = Clock::now();
  const std::shared_ptr<warp::Icaz> plain = engines.get(e, warp::Saliency::kDefault, s.lines);
  const double plain_load_ms = ms_since(t0);
  // The stored model: the curator's lines as drawn (a line set's model holds them with the
  // detected ones cut back), and the map of the salient region.
  const warp::ImageModel& stored = engines.get(e, warp::Saliency::kDefault, warp::LineSet::kCurator)->model();
  const warp::SignificanceMap map = warp::saliency_map(e, reader, stored, s.saliency);
  // The lines that must stay straight, whatever --lines gives the methods: the curator's and the
  // detected ones not dismissed.
  std::vector<warp::Segment> lines = stored.lines;
  for (const warp::Segment& l : warp::suggested_lines(e, reader, stored)) lines.push_back(l);
  const std::vector<Contender> contenders = make_contenders(s, engines, e, reader, plain, plain_load_ms);

  const bool progress = ::isatty(STDERR_FILENO);
  std::vector<std::vector<warp::SheetCell>> sheet;
  for (std::size_t k = 0; k < contenders.size(); ++k) {
    const Contender& c = contenders[k];
    report["methods"].push_back({{"name", c.name}, {"has_mesh", c.has_mesh}, {"precompute_ms", c.precompute_ms}});
    std::vector<warp::SheetCell>& row = sheet.emplace_back();
    for (double z : s.zooms) {
      warp::ViewRequest r;
      r.zoom = z, r.cx = e.manifest.width / 2.0, r.cy = e.manifest.height / 2.0;
      r.screen_width = s.screen_width, r.screen_height = s.screen_height;
      Cell cell;
      cell.zoom = z;
      const auto start = Clock::now();
      tiles::Raster shown = c.render(r);
      cell.viewport_ms = ms_since(start);
      cell.metrics = c.has_mesh ? warp::mesh_view_metrics(c.view(r), plain->traditional(r), map, lines, s.screen_width,
                                                          s.screen_height)
                                : warp::raster_view_metrics(shown, c.screen_sources(r), plain->traditional(r), map);
      report["rows"].push_back(row_json(c.name, cell));
      row.push_back({std::move(shown), label(c.name, cell)});
    }
    if (progress)
      std::fprintf(stderr, "compare: %s done (%zu/%zu), precompute %.0f ms\n", c.name.c_str(), k + 1, contenders.size(),
                   c.precompute_ms);
  }
  return sheet;
}

}  // namespace

int compare_command(const std::vector<std::string>& raw_args) {
  std::vector<OptionSpec> specs = {
      {"methods", "all", "all, or a comma-separated list of: " + joined(known_methods())},
      {"size", "360x640", "screen WIDTHxHEIGHT"},
      {"zoom", "0,0.5,1", "zoom levels, comma-separated, each in [0, 1]"},
      {"saliency", "default", "default or gbvs: the map that drives the methods and defines the salient region"},
      {"lines", "auto", "auto, curator or none: the lines the methods keep straight (the bend is measured on auto's)"},
      {"image", "", "an image id of --store instead of an IMAGE file"},
      {"out", "", "output folder (also -o)"},
  };
  for (auto& s : store_option_specs()) specs.push_back(s);
  std::vector<std::string> args = raw_args;
  for (auto& a : args)
    if (a == "-o") a = "--out";
  return run_command("compare", [&]() -> int {
    const Options o(specs, args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    const Settings s = parse_settings(o);
    const warp::SignificanceOptions significance = analysis_settings(o).significance;
    json report;
    std::optional<TemporaryStore> temporary;  // an IMAGE file is ingested into it
    std::string store_root = o.str("store"), id = s.image_id;
    if (!s.file.empty()) {
      temporary.emplace();
      store_root = temporary->path(), id = "image";
      tiles::Store store(store_root);
      const auto t0 = Clock::now();
      tiles::ingest_image(store, s.file, id, ingest_options(o, significance));
      report["ingest_ms"] = ms_since(t0);
    }
    tiles::Store store(store_root);
    const auto entry = store.find(id);
    if (!entry) throw std::invalid_argument("no image '" + id + "' in the store " + store_root);
    report["image"] = s.file.empty() ? id : std::filesystem::path(s.file).filename().string();
    report["width"] = entry->manifest.width, report["height"] = entry->manifest.height;
    report["screen"] = {s.screen_width, s.screen_height};
    report["saliency"] = std::string(warp::saliency_name(s.saliency));
    report["lines"] = std::string(warp::line_set_name(s.lines));
    report["zooms"] = s.zooms;
    report["methods"] = json::array();
    report["rows"] = json::array();
    tiles::PyramidReader reader(256 << 20);
    const auto sheet = run(s, *entry, reader, significance, report);

    std::filesystem::create_directories(s.out);
    write_file(s.out / "sheet.png", tiles::encode_image(warp::contact_sheet(sheet), tiles::ImageFormat::kPng, {}));
    write_file(s.out / "metrics.json", report.dump(2) + "\n");
    write_file(s.out / "metrics.md", markdown(report));
    std::printf("wrote %s, %s and %s\n", (s.out / "sheet.png").c_str(), (s.out / "metrics.json").c_str(),
                (s.out / "metrics.md").c_str());
    return 0;
  });
}

}  // namespace zoomwarp::server
