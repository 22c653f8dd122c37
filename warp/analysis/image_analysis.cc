#include "warp/analysis/image_analysis.h"

#include <algorithm>
#include <array>
#include <boost/crc.hpp>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>
#include <stdexcept>

#include "tiles/parallel_jobs.h"
#include "warp/analysis/analysis_image.h"
#include "warp/analysis/derived_files.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/method_files.h"
#include "warp/analysis/model_file.h"
#include "warp/core/limits.h"
#include "warp/saliency/gbvs.h"

namespace zoomwarp::warp {

namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Formats 1 (no trailer) and 2 (floats) are still read; format 3 (compact) is written.
constexpr SaliencyFileMagics kSignificanceMagics = {{'Z', 'W', 'S', 'I', 'G', '1', 0, 0},
                                                    {'Z', 'W', 'S', 'I', 'G', '2', 0, 0},
                                                    {'Z', 'W', 'S', 'I', 'G', '3', 0, 0}};
constexpr Magic kModelMagic1 = {'Z', 'W', 'M', 'O', 'D', 'E', 'L', '1'};
constexpr Magic kModelMagic2 = {'Z', 'W', 'M', 'O', 'D', 'E', 'L', '2'};

json point_json(const Point& p) { return json::array({p.x, p.y}); }
Point point_from(const json& j) { return {j.at(0).get<double>(), j.at(1).get<double>()}; }

json segments_json(const std::vector<Segment>& segments) {
  json out = json::array();
  for (const Segment& s : segments) out.push_back({{"from", point_json(s.a)}, {"to", point_json(s.b)}});
  return out;
}
std::vector<Segment> segments_from(const json& j) {
  std::vector<Segment> out;
  for (const auto& l : j) out.push_back({point_from(l.at("from")), point_from(l.at("to"))});
  return out;
}

std::string model_json(const ImageModel& m) {
  json edits = json::array();
  for (const SignificanceEdit& e : m.edits) {
    json polygon = json::array();
    for (const Point& p : e.polygon) polygon.push_back(point_json(p));
    edits.push_back({{"polygon", polygon}, {"weight", e.weight}});
  }
  return json{{"lines", segments_json(m.lines)},
              {"significance_edits", edits},
              {"dismissed_lines", segments_json(m.dismissed_lines)}}
             .dump(2) + "\n";
}

// The shape rules every edit and every stored warp.json keeps (the count limits apply to new
// edits only: warp.json may hold many edits). Throws std::invalid_argument.
void validate_shapes(const ModelEdit& edit) {
  auto finite = [](const Point& p) { return std::isfinite(p.x) && std::isfinite(p.y); };
  for (const auto* lines : {&edit.lines, &edit.dismissed_lines})
    for (const Segment& s : lines->value_or(std::vector<Segment>{})) {
      if (!finite(s.a) || !finite(s.b)) throw std::invalid_argument("line end points must be finite numbers");
      if (std::hypot(s.b.x - s.a.x, s.b.y - s.a.y) < 1) throw std::invalid_argument("a line must be at least 1 px long");
    }
  for (const SignificanceEdit& e : edit.significance) {
    if (e.polygon.size() < 3) throw std::invalid_argument("a region needs at least 3 points");
    for (const Point& p : e.polygon)
      if (!finite(p)) throw std::invalid_argument("region points must be finite numbers");
    if (!(e.weight >= 0 && e.weight <= 1)) throw std::invalid_argument("a region's weight must be in [0, 1]");
  }
}


// warp.json: the curator's lines, significance edits and dismissed suggestions, checked like a
// new edit would be. A warp.json from before line detection has no "dismissed_lines": none.
ModelEdit read_model_json(const tiles::ImageEntry& image) {
  ModelEdit stored;
  try {
    const json j = json::parse(read_whole(image, kModelJsonFile));
    stored.lines = segments_from(j.at("lines"));
    stored.dismissed_lines = segments_from(j.value("dismissed_lines", json::array()));
    for (const auto& e : j.at("significance_edits")) {
      SignificanceEdit edit;
      for (const auto& p : e.at("polygon")) edit.polygon.push_back(point_from(p));
      edit.weight = e.at("weight").get<float>();
      stored.significance.push_back(std::move(edit));
    }
    validate_shapes(stored);
  } catch (const json::exception& e) {
    throw ModelFileError(kModelJsonFile, e.what());
  } catch (const std::invalid_argument& e) {
    throw ModelFileError(kModelJsonFile, e.what());
  }
  return stored;
}

std::string model_bytes(const ImageModel& m) {
  std::ostringstream out;
  out.write(kModelMagic2.data(), kModelMagic2.size());
  put(out, m.width), put(out, m.height), put(out, m.w_min), put(out, m.coarse.max_triangle_area);
  put_vector(out, m.coarse.mesh.vertices);
  put_vector(out, m.coarse.mesh.triangles);
  put(out, std::int64_t(m.coarse.line_vertices.size()));
  for (const auto& chain : m.coarse.line_vertices) put_vector(out, chain);
  m.forest.write(out);
  put_vector(out, m.node_mean);
  return with_trailer(out.str());
}

// warp_model.bin into `m`, whose lines (from warp.json) its line chains must match.
void read_model_bin(const tiles::ImageEntry& image, ImageModel& m) {
  auto [bytes, format] = checked_payload(kModelFile, read_whole(image, kModelFile), kModelMagic1, kModelMagic2);
  ModelFileReader in(kModelFile, std::move(bytes));
  in.stream().seekg(std::streamoff(kModelMagic1.size()));
  m.width = in.get<double>(), m.height = in.get<double>(), m.w_min = in.get<double>();
  m.coarse.max_triangle_area = in.get<double>();
  if (m.width != image.manifest.width || m.height != image.manifest.height) in.damaged("made for another image size");
  m.coarse.mesh.vertices = in.get_vector<Point>();
  m.coarse.mesh.triangles = in.get_vector<Triangle>();
  for (const Triangle& t : m.coarse.mesh.triangles)
    for (int v : t)
      if (v < 0 || v >= int(m.coarse.mesh.vertices.size())) in.damaged("a triangle names a missing vertex");
  const auto chains = in.get<std::int64_t>();
  if (chains != std::int64_t(m.lines.size())) in.damaged("its line constraints are not warp.json's");
  for (std::int64_t k = 0; k < chains; ++k) m.coarse.line_vertices.push_back(in.get_vector<int>());
  try {
    m.forest = Forest::read(in.stream(), m.coarse.mesh);
  } catch (const std::runtime_error& e) {
    in.damaged(e.what());
  }
  m.node_mean = in.get_vector<float>();
  if (m.node_mean.size() != std::size_t(m.forest.kept_nodes())) in.damaged("node means do not match the forest");
  if (format == 2 && in.remaining() != 0) in.damaged("trailing bytes");
}

// The analysis's jobs run side by side on the ingest's threads while their estimated peaks sum to
// at most this, so that the memory an ingest adds for its analysis stays near it whatever the
// image (issue 18). On the 952 MP test image (996×934 analysis pixels) seam carving's or patch
// segmentation's precomputation (~45 MB) runs beside polyfem's and mp's but not beside each other
// (1.5 s of the analysis's 8.6 taken off its critical path for a peak within vips dzsave's 1.5×);
// with up to 0.69 MP of analysis pixels (most images), any two of the methods' jobs pair.
constexpr std::size_t kAnalysisMemoryBudget = 72 << 20;
// The inputs' jobs (faces, detected lines) and the maps' (the model, GBVS): their peaks per
// analysis pixel, measured as the methods' are (RetargetingMethod::precompute_bytes_per_pixel).
constexpr std::size_t kInputBytesPerPixel = 66, kMapBytesPerPixel = 36;

}  // namespace

std::optional<AnalysisSet> parse_analysis_set(std::string_view name) {
  if (name == "none") return AnalysisSet::kNone;
  if (name == "icaz") return AnalysisSet::kIcaz;
  if (name == "all") return AnalysisSet::kAll;
  return std::nullopt;
}

std::vector<MethodFileTiming> write_image_analysis(const tiles::ImageEntry& image,
                                                   const SignificanceOptions& significance, int threads,
                                                   AnalysisSet set) {
  if (set == AnalysisSet::kNone) return {};
  tiles::PyramidReader reader(32 << 20);  // its own small cache: staged files are about to move
  const tiles::Raster analysis = read_reduced_image(image, reader);
  // The faces and the detected lines read only the analysis image; the model and the GBVS map
  // read it and the faces, found once for both (a detection costs as much as either map). The
  // methods' precomputations read all of it (the lines and the GBVS map from their files).
  const std::size_t pixels = std::size_t(analysis.width) * std::size_t(analysis.height);
  SignificanceOptions with_faces = significance;
  const tiles::Job inputs[] = {
      {[&] { with_faces.faces = detect_faces(analysis, significance.face_cascade); }, kInputBytesPerPixel * pixels},
      {[&] { write_detected_lines(image, reader); }, kInputBytesPerPixel * pixels},
  };
  tiles::run_jobs(inputs, threads, kAnalysisMemoryBudget);
  ImageModel model;
  if (set == AnalysisSet::kIcaz) {
    model = make_image_model(analysis, image.manifest.width, image.manifest.height, {}, {}, {}, with_faces);
    write_image_model(*image.files, model);
    return {};
  }
  const tiles::Job maps[] = {
      {[&] {
         model = make_image_model(analysis, image.manifest.width, image.manifest.height, {}, {}, {}, with_faces);
         write_image_model(*image.files, model);
       },
       kMapBytesPerPixel * pixels},
      {[&] { write_gbvs_map(*image.files, gbvs_significance(analysis, image.manifest.width, with_faces)); },
       kMapBytesPerPixel * pixels},
  };
  tiles::run_jobs(maps, threads, kAnalysisMemoryBudget);
  return write_method_files(*image.files, image, reader, model, method_files(kSaliencies), threads, kAnalysisMemoryBudget);
}

std::vector<std::string> add_missing_analyses(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                              const SignificanceOptions& significance, AnalysisSet set, int threads) {
  const std::vector<std::string> before = stored_analyses(image);
  if (set == AnalysisSet::kNone) return {};
  // The lazy paths add what is missing (derived_files.h); the methods' files side by side, as ingest does.
  const LoadedModel loaded = load_image_model(image, reader, significance);
  read_detected_lines(image, reader);
  if (set == AnalysisSet::kAll) {
    load_saliency_map(image, reader, loaded.model, Saliency::kGbvs, significance);
    std::vector<MethodFile> missing;
    for (const MethodFile& f : method_files(kSaliencies))
      if (!exists(image, method_file_name(*f.method, f.saliency).c_str())) missing.push_back(f);
    write_method_files(*image.files, image, reader, loaded.model, missing, threads, kAnalysisMemoryBudget);
  }
  std::vector<std::string> added;
  for (const std::string& name : stored_analyses(image))
    if (std::find(before.begin(), before.end(), name) == before.end()) added.push_back(name);
  return added;
}

void write_image_model(const tiles::VersionFiles& files, const ImageModel& model) {
  // warp.json first: binary files without it would read as a model whose curator edits are lost.
  files.write(kModelJsonFile, model_json(model));
  files.write(kSignificanceFile, saliency_map_bytes(model.significance, kSignificanceMagics));
  files.write(kModelFile, model_bytes(model));
}

SignificanceMap read_significance(const tiles::ImageEntry& image) {
  return read_saliency_map_file(image, kSignificanceFile, kSignificanceMagics);
}

ImageModel read_image_model(const tiles::ImageEntry& image) {
  ModelEdit stored = read_model_json(image);
  ImageModel m;
  m.lines = std::move(*stored.lines);
  m.straight_lines = m.lines;
  m.edits = std::move(stored.significance);
  m.dismissed_lines = std::move(*stored.dismissed_lines);
  m.significance = read_significance(image);
  read_model_bin(image, m);
  return m;
}

namespace {

// The default variant: the version's files, or built or rebuilt from the pyramid.
LoadedModel load_default_model(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                               const SignificanceOptions& significance) {
  const auto rebuild = [&](const std::vector<Segment>& lines) {
    return make_image_model(read_reduced_image(image, reader), image.manifest.width, image.manifest.height, lines, {},
                            {}, significance);
  };
  if (!exists(image, kSignificanceFile) && !exists(image, kModelFile) && !exists(image, kModelJsonFile)) {
    // Never analysed (issue 28: the model is made on first use): made now and kept with the
    // version — warp.json first, so that no reader finds binary files without it — then read
    // back as every later load reads it.
    ImageModel model = rebuild({});
    try {
      write_image_model(*image.files, model);
      model = read_image_model(image);
    } catch (const std::exception&) {
      // A folder we cannot write (read-only store, a version collected meanwhile): from memory.
    }
    return {std::move(model), ModelSource::kBuiltNoFiles, "", ""};
  }
  // warp.json is the only copy of the curator's work: without it, no model (ModelFileError).
  const ModelEdit stored = read_model_json(image);
  try {
    return {read_image_model(image), ModelSource::kStored, "", ""};
  } catch (const ModelFileError& damaged) {
    // [ICAZ §4] The binary files are derived data: the significance map is recomputed from the
    // pyramid with the curator's regions painted in, the mesh and forest rebuilt with the lines.
    LoadedModel out{rebuild(*stored.lines), ModelSource::kRebuiltWithEdits, damaged.file(), damaged.what()};
    add_significance_edits(out.model, stored.significance);
    out.model.dismissed_lines = *stored.dismissed_lines;
    return out;
  }
}

}  // namespace

LoadedModel load_image_model(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                             const SignificanceOptions& significance, const ModelVariant& variant) {
  LoadedModel loaded = load_default_model(image, reader, significance);
  if (variant.saliency != Saliency::kDefault) {
    // The same mesh and forest; the map and the node means are the kind's.
    LoadedSaliency map = load_saliency_map(image, reader, loaded.model, variant.saliency, significance);
    set_significance(loaded.model, std::move(map.map));
    if (!map.damaged.empty() && loaded.source == ModelSource::kStored)
      loaded = {std::move(loaded.model), ModelSource::kRebuiltWithEdits, kGbvsFile, map.damaged};
  }
  if (variant.lines == LineSet::kCurator) return loaded;
  LoadedModel lined = with_line_set(std::move(loaded.model), image, reader, variant.lines);
  lined.source = loaded.source, lined.damaged_file = loaded.damaged_file, lined.reason = loaded.reason;
  return lined;
}

LoadedModel with_line_set(ImageModel model, const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                          LineSet lines) {
  LoadedModel out{std::move(model), ModelSource::kStored, "", ""};
  if (lines == LineSet::kAuto) {
    // [ICAZ §4.3] The detected lines [Guo09 §3.3.3] constrain the warp like the curator's: the
    // coarsest mesh, the forest and its node means are rebuilt with them, in memory.
    const auto suggested = suggested_lines(image, reader, out.model);
    std::vector<Segment> straight = out.model.lines;
    straight.insert(straight.end(), suggested.begin(), suggested.end());
    set_lines(out.model, auto_line_set(out.model, suggested, &out.unmeshable_suggestions));
    out.model.straight_lines = std::move(straight);
  } else if (lines == LineSet::kNone && !out.model.lines.empty()) {
    set_lines(out.model, {});
  }
  return out;
}

void validate(const ModelEdit& edit) {
  if (edit.lines && edit.lines->size() > std::size_t(limits::kMaxLines))
    throw LimitExceeded("too_many_lines", "at most " + std::to_string(limits::kMaxLines) + " lines");
  // No more can be detected (line_detection.h), so no more can be dismissed.
  if (edit.dismissed_lines && edit.dismissed_lines->size() > std::size_t(limits::kMaxLines))
    throw LimitExceeded("too_many_lines", "at most " + std::to_string(limits::kMaxLines) + " dismissed lines");
  if (edit.significance.size() > std::size_t(limits::kMaxRegionsPerEdit))
    throw LimitExceeded("too_many_regions", "at most " + std::to_string(limits::kMaxRegionsPerEdit) + " regions per edit");
  for (const SignificanceEdit& e : edit.significance)
    if (e.polygon.size() > std::size_t(limits::kMaxPolygonPoints))
      throw LimitExceeded("too_many_points", "a polygon has at most " + std::to_string(limits::kMaxPolygonPoints) + " points");
  validate_shapes(edit);
}

std::shared_ptr<const tiles::ImageEntry> edit_image_model(tiles::Store& store, const tiles::ImageEntry& current,
                                                          const ModelEdit& edit, std::optional<ImageModel> base) {
  validate(edit);
  ImageModel model = base ? std::move(*base) : read_image_model(current);
  // Only edits that add regions are held to the cap: new lines stay possible on an image that
  // an earlier version let keep more regions.
  if (!edit.significance.empty() && model.edits.size() + edit.significance.size() > std::size_t(limits::kMaxStoredRegions))
    throw LimitExceeded("too_many_stored_regions", "an image keeps at most " + std::to_string(limits::kMaxStoredRegions) +
                        " significance regions over all its edits; it has " + std::to_string(model.edits.size()));
  add_significance_edits(model, edit.significance);
  // New lines rebuild the mesh and the forest, whose node means then read the edited map.
  if (edit.lines) set_lines(model, *edit.lines);
  if (edit.dismissed_lines) model.dismissed_lines = *edit.dismissed_lines;
  const std::string staging = store.make_staging_copy(current);
  const auto staged = tiles::folder_files(staging);
  try {
    write_image_model(*staged, model);
    // The methods read the significance map (as seam carving's bias, as mp's objects): those the
    // version holds are precomputed again from the edited one, on the same pyramid; those that
    // read lines (mp's constrained mesh) also when only the lines or the dismissed suggestions
    // changed. Those it does not hold are made on first use, as for any version (issue 28).
    if (!edit.significance.empty() || edit.lines || edit.dismissed_lines) {
      tiles::PyramidReader reader(32 << 20);
      write_method_files(*staged, current, reader, model,
                         stored_method_files(current, edit.significance.empty() ? MethodSelection::kReadingLines
                                                                                : MethodSelection::kAll));
    }
  } catch (...) {
    store.discard(staging);
    throw;
  }
  return store.publish(staging, current.manifest, &current.manifest.version);
}

}  // namespace zoomwarp::warp
