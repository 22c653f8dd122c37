#include "warp/analysis/detected_lines.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "warp/analysis/analysis_image.h"
#include "warp/analysis/derived_files.h"
#include "warp/analysis/model_file.h"
#include "warp/core/limits.h"
#include "warp/lines/line_detection.h"
#include "warp/meshing/coarse_mesh.h"

namespace zoomwarp::warp {

namespace {

using nlohmann::json;

// Names the detector and its parameters: a file from another one is detected again.
constexpr const char* kDetector = "canny+houghp/1";

double length(const Segment& s) { return std::hypot(s.b.x - s.a.x, s.b.y - s.a.y); }

// 1/100 px is far below what a line constraint can tell, and keeps the file readable.
double rounded(double v) { return std::round(v * 100) / 100; }

std::vector<Segment> detect(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  return detect_lines(read_reduced_image(image, reader), image.manifest.width, image.manifest.height);
}

// The file's lines if it is intact and this detector's: finite, inside the image, within the limits.
std::optional<std::vector<Segment>> parse(const std::string& text, double W, double H) {
  const json j = json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.contains("detector") || j["detector"] != kDetector || !j.contains("lines") || !j["lines"].is_array() ||
      j["lines"].size() > std::size_t(limits::kMaxLines))
    return std::nullopt;
  std::vector<Segment> lines;
  for (const json& l : j["lines"]) {
    if (!l.is_array() || l.size() != 4) return std::nullopt;
    double v[4];
    for (int k = 0; k < 4; ++k) {
      if (!l[k].is_number()) return std::nullopt;
      v[k] = l[k].get<double>();
      if (!std::isfinite(v[k]) || v[k] < 0 || v[k] > (k % 2 ? H : W)) return std::nullopt;
    }
    lines.push_back({{v[0], v[1]}, {v[2], v[3]}});
    if (length(lines.back()) < 1) return std::nullopt;
  }
  return lines;
}

bool meshes(const ImageModel& model, const std::vector<Segment>& lines) {
  try {
    build_coarse_mesh(model.width, model.height, lines);
    return true;
  } catch (const std::invalid_argument&) {
    return false;
  }
}

// The file's text for the lines detected in `image`.
std::string detected_lines_text(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  json lines = json::array();
  for (const Segment& s : detect(image, reader))
    lines.push_back({rounded(s.a.x), rounded(s.a.y), rounded(s.b.x), rounded(s.b.y)});
  return json{{"detector", kDetector}, {"lines", lines}}.dump(1) + "\n";
}

}  // namespace

void write_detected_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  image.files->write(kDetectedLinesFile, detected_lines_text(image, reader));
}

std::vector<Segment> read_detected_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  if (exists(image, kDetectedLinesFile)) {
    try {
      if (auto stored = parse(read_whole(image, kDetectedLinesFile), image.manifest.width, image.manifest.height))
        return *stored;
    } catch (const ModelFileError&) {
      // Vanished or unreadable between the two calls: detected again below, like a damaged one.
    }
  }
  if (exists(image, kDetectedLinesFile)) return detect(image, reader);
  // Never detected for this version (issue 28: on first use): detected now and kept with it, as
  // the file gives them back (rounded), so that this process and every later one see one set.
  const std::string text = detected_lines_text(image, reader);
  auto lines = parse(text, image.manifest.width, image.manifest.height);
  if (!lines) throw std::logic_error("the detector's own lines do not read back");
  add_derived_file(image, kDetectedLinesFile, text);
  return std::move(*lines);
}

std::vector<Segment> suggested_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                     const ImageModel& model) {
  return remaining_suggestions(read_detected_lines(image, reader), model.lines, model.dismissed_lines, model.width,
                               model.height);
}

std::vector<Segment> auto_line_set(const ImageModel& model, const std::vector<Segment>& suggestions, int* dropped) {
  std::vector<Segment> lines = model.lines;
  double total = 0;
  for (const Segment& s : lines) total += length(s);
  const double max_total = limits::kMaxTotalLineLength * std::max(model.width, model.height);
  // Clearance and shortest piece (ours): a quarter and a half of the point spacing d of
  // [Guo09 §3.2] (N = 300), in image pixels.
  const double d = std::sqrt(model.width * model.height / 300);
  std::vector<Segment> admitted;
  for (const Segment& s : suggestions)
    for (const Segment& piece : clear_pieces(s, lines, d / 4, d / 2)) {
      if (lines.size() >= std::size_t(limits::kMaxLines) || total + length(piece) > max_total) continue;
      total += length(piece);
      lines.push_back(piece);
      admitted.push_back(piece);
    }
  if (dropped) *dropped = 0;
  if (admitted.empty() || meshes(model, lines)) return lines;
  // [ICAZ §4.1] Should CGAL still refuse the set, add the pieces one by one and leave out each
  // that breaks the mesh; the curator's lines mesh (they did when they were saved).
  lines = model.lines;
  for (const Segment& s : admitted) {
    lines.push_back(s);
    if (!meshes(model, lines)) {
      lines.pop_back();
      if (dropped) ++*dropped;
    }
  }
  return lines;
}

}  // namespace zoomwarp::warp
