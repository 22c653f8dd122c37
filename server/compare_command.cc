// `zoomwarp compare IMAGE --methods … --size WxH --zoom … -o DIR`: one comparison bench for every
// retargeting method (docs/compare.md). Each cell (method × zoom) is rendered by the code
// /viewport runs (api::WarpEngines::view_engine, Retargeter::render) and measured
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
#include <nlohmann/json.hpp>
#include <sstream>
#include <tuple>

#include "api/framed_views.h"
#include "api/view_methods.h"
#include "api/warp_engines.h"
#include "server/commands.h"
#include "server/compare_report.h"
#include "server/settings.h"
#include "tiles/encode.h"
#include "tiles/ingest.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/line_set.h"
#include "warp/analysis/method_files.h"
#include "warp/analysis/analysis_image.h"
#include "warp/compare/contact_sheet.h"
#include "warp/compare/independent_saliency.h"
#include "warp/compare/metrics.h"
#include "warp/compare/smart_crop.h"
#include "warp/core/limits.h"

namespace zoomwarp::server {

namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

double ms_since(Clock::time_point t0) { return std::chrono::duration<double, std::milli>(Clock::now() - t0).count(); }

constexpr std::size_t kMaxZooms = 16;

// The methods `--methods` may name: every method a view may name (api/view_methods.h).
std::vector<std::string> known_methods() {
  std::vector<std::string> out;
  for (const api::ViewMethod& m : api::view_methods()) out.emplace_back(m.name());
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

// One method as the comparison sees it: the engine /viewport draws it with.
struct Contender {
  std::string name;
  double precompute_ms = 0;  // the engine's first load: model files read, method loaded
  std::shared_ptr<warp::Retargeter> engine;
};

void write_file(const std::filesystem::path& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out << bytes;
  if (!out.flush()) throw std::runtime_error("cannot write " + path.string());
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
  std::vector<warp::Fit> fits;  // a row per method and fit
  double max_distortion = warp::kDefaultMaxDistortion;
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
  for (const std::string& name : split(o.str("fits"), ',')) {
    const auto fit = warp::parse_fit(name);
    if (!fit) throw std::invalid_argument("--fits takes auto, warp, crop or pad separated by commas, not '" + name + "'");
    if (std::find(s.fits.begin(), s.fits.end(), *fit) != s.fits.end())
      throw std::invalid_argument("--fits names " + name + " twice");
    s.fits.push_back(*fit);
  }
  if (s.fits.empty()) throw std::invalid_argument("--fits names no fit");
  char* end = nullptr;
  const std::string budget = o.str("max-distortion");
  s.max_distortion = std::strtod(budget.c_str(), &end);
  if (budget.empty() || *end != 0 || !(s.max_distortion >= warp::kMinMaxDistortion && s.max_distortion <= warp::kMaxMaxDistortion))
    throw std::invalid_argument("--max-distortion must be a number from 1 to 8, not '" + budget + "'");
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

// The engines of the methods compared, each timed on its first load. api's own methods draw with
// the ICAZ operator: the default-saliency one is loaded first as the reference (`plain`), and its
// load (model files read, coarsest mesh factored) counts as the precomputation of each that uses it.
std::vector<Contender> make_contenders(const Settings& s, api::WarpEngines& engines, const tiles::ImageEntry& e,
                                       double plain_load_ms) {
  std::vector<Contender> out;
  for (const std::string& name : s.methods) {
    const api::ViewMethod& method = *api::find_view_method(name);
    Contender c;
    c.name = name;
    const auto t0 = Clock::now();
    c.engine = engines.view_engine(e, method, s.saliency, s.lines);
    c.precompute_ms = ms_since(t0);
    if (!method.registered && (!method.reads_saliency || s.saliency == warp::Saliency::kDefault))
      c.precompute_ms += plain_load_ms;
    out.push_back(std::move(c));
  }
  return out;
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
  const std::vector<Contender> contenders = make_contenders(s, engines, e, plain_load_ms);

  // Issue 41's judge: a saliency map no method optimises, and what a user would pick instead of a
  // warp, the attention smart crop (drawn as traditional zoom covering the screen from its centre).
  const tiles::Raster analysis = warp::read_reduced_image(e, reader);
  const warp::SignificanceMap independent = warp::independent_saliency(analysis, e.manifest.width);
  const warp::Point crop_centre =
      warp::attention_crop_centre(analysis, e.manifest.width, e.manifest.height, s.screen_width, s.screen_height);
  api::ViewFraming framing(engines);

  const bool progress = ::isatty(STDERR_FILENO);
  std::vector<std::vector<warp::SheetCell>> sheet;
  // A row of the sheet: `method` drawn with `fit` at every zoom (labelled "method fit" when the
  // run compares fits), each cell a row of metrics.json.
  const auto measure = [&](const std::string& method, const std::string& fit, const std::string& label, auto draw) {
    std::vector<warp::SheetCell>& row = sheet.emplace_back();
    for (double z : s.zooms) {
      warp::ViewRequest r;
      r.zoom = z, r.cx = e.manifest.width / 2.0, r.cy = e.manifest.height / 2.0;
      r.screen_width = s.screen_width, r.screen_height = s.screen_height;
      Cell cell;
      cell.zoom = z;
      const auto start = Clock::now();
      const auto [engine, framed] = draw(r);
      tiles::Raster shown = engine->render(framed, e, reader);
      cell.viewport_ms = ms_since(start);
      const warp::View reference = plain->traditional(r);
      if (engine->has_mesh()) {
        const warp::View view = engine->view(framed);
        cell.metrics = warp::mesh_view_metrics(view, reference, map, lines, s.screen_width, s.screen_height);
        cell.independent = warp::squash_measures(view, independent, s.screen_width, s.screen_height);
      } else {
        const std::vector<warp::Point> sources = engine->screen_sources(framed);
        cell.metrics = warp::raster_view_metrics(shown, sources, reference, map);
        cell.independent = warp::squash_measures_of_sources(sources, independent);
      }
      json row_json = cell_json(method, cell);
      row_json["fit"] = fit;
      report["rows"].push_back(row_json);
      row.push_back({std::move(shown), cell_label(label, cell)});
    }
  };
  for (std::size_t k = 0; k < contenders.size(); ++k) {
    const Contender& c = contenders[k];
    report["methods"].push_back(
        {{"name", c.name}, {"has_mesh", c.engine->has_mesh()}, {"precompute_ms", c.precompute_ms}});
    for (warp::Fit fit : s.fits) {
      api::ViewQuery q;  // as /viewport parses it, framed as the routes frame it
      q.method = api::find_view_method(c.name), q.saliency = s.saliency, q.lines = s.lines;
      q.fit = {fit, s.max_distortion};
      if (!q.method->takes_lines()) q.lines = warp::LineSet::kCurator;
      const std::string fit_name(warp::fit_name(fit));
      measure(c.name, fit_name, s.fits.size() > 1 ? c.name + " " + fit_name : c.name, [&](const warp::ViewRequest& r) {
        q.view = r;
        api::FramedQuery framed = framing.frame(e, q, nullptr, false);
        return std::pair{framed.engine, framed.view};
      });
    }
    if (progress)
      std::fprintf(stderr, "compare: %s done (%zu/%zu), precompute %.0f ms\n", c.name.c_str(), k + 1, contenders.size(),
                   c.precompute_ms);
  }
  const std::shared_ptr<warp::Retargeter> traditional =
      engines.view_engine(e, *api::find_view_method("traditional"), warp::Saliency::kDefault, s.lines);
  measure("smart crop", "crop", "smart crop", [&](const warp::ViewRequest& r) {
    warp::ViewRequest cropped = r;
    cropped.cx = crop_centre.x, cropped.cy = crop_centre.y, cropped.frame.cover = true;
    return std::pair{traditional, cropped};
  });
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
      {"fits", "auto,warp", "fit= values, comma-separated: a row per method and fit (auto, warp, crop, pad)"},
      {"max-distortion", "1.4", "fit=auto's budget, 1…8"},
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
    report["fits"] = json::array();
    for (warp::Fit f : s.fits) report["fits"].push_back(std::string(warp::fit_name(f)));
    report["max_distortion"] = s.max_distortion;
    report["zooms"] = s.zooms;
    report["methods"] = json::array();
    report["rows"] = json::array();
    tiles::PyramidReader reader(256 << 20);
    const auto sheet = run(s, *entry, reader, significance, report);

    std::filesystem::create_directories(s.out);
    write_file(s.out / "sheet.png", tiles::encode_image(warp::contact_sheet(sheet), tiles::ImageFormat::kPng, {}));
    write_file(s.out / "metrics.json", report.dump(2) + "\n");
    write_file(s.out / "metrics.md", report_markdown(report));
    std::printf("wrote %s, %s and %s\n", (s.out / "sheet.png").c_str(), (s.out / "metrics.json").c_str(),
                (s.out / "metrics.md").c_str());
    return 0;
  });
}

}  // namespace zoomwarp::server
