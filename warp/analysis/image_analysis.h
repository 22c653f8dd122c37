// The warp engine's files in an image version's folder, written on the version's first view
// (derived_files.h), at ingest when asked (AnalysisSet) and by curator edits, so that a view
// never touches full-resolution pixels and a server builds an image's operator
// without CGAL or the face detector:
//
//   significance.bin   the significance map (≤ 1024 px, floats), edits painted in
//   warp_model.bin     the coarsest mesh, the forest's kept nodes (as their split order) and
//                      every kept node's mean significance
//   warp.json          what the user gave: line constraints, significance edits and the
//                      detected lines they dismissed (analysis/detected_lines.h), readable
//   gbvs.bin           the GBVS map (saliency=gbvs, ≤ 1024 px, floats), faces painted in but not
//                      the edits: they are painted when it is loaded (method_files.h
//                      saliency_map), so an edit's new version keeps it as a hard link
//
// The binary files (format 2) end in a trailer — the byte count before it and their CRC-32 — so
// a truncated or damaged file is detected before it is parsed; format 1 files (no trailer),
// written by earlier versions, are still read. warp.json is the only copy of the curator's work;
// the binary files can be rebuilt from it and the pyramid (load_image_model).
//
// An edit never changes a published version: it publishes a new one (hard links to the same
// pyramid, new model files), conditional on the version it started from. A version without any
// model file is analysed on first use: warp.json (no lines, no edits) is written before the
// binary files, so a reader never finds those without it.
//
// Thread safety: free functions on immutable published folders; safe to call concurrently.
#pragma once

#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/analysis/line_set.h"
#include "warp/analysis/method_files.h"
#include "warp/analysis/model_file.h"
#include "warp/analysis/saliency_files.h"
#include "warp/icaz/image_model.h"
#include "warp/saliency/saliency.h"

namespace zoomwarp::warp {

inline constexpr const char* kSignificanceFile = "significance.bin";
inline constexpr const char* kModelFile = "warp_model.bin";
inline constexpr const char* kModelJsonFile = "warp.json";

// What an ingest analyses before it publishes (issue 28): by default nothing — every analysis
// is made on first use and kept with the version (derived_files.h) — or ICAZ's model and the
// detected lines (kIcaz), or everything every method may need for both saliency kinds (kAll:
// `zoomwarp ingest --analyses all`, `zoomwarp analyse`).
enum class AnalysisSet { kNone, kIcaz, kAll };
std::optional<AnalysisSet> parse_analysis_set(std::string_view name);  // "none", "icaz", "all"

// The ingest hook: writes `set`'s files into the (still staged) folder — for kAll the model (no
// lines yet), the GBVS map, the detected lines and the retargeting methods' files (method_files.h)
// for every saliency kind — on up to `threads` threads, while the jobs running at once are
// estimated to hold at most 72 MB, so fewer for large analysis images (the files are the same for
// any count). Returns how long each method file took. Throws std::runtime_error if it cannot write.
std::vector<MethodFileTiming> write_image_analysis(const tiles::ImageEntry& image,
                                                   const SignificanceOptions& significance = {}, int threads = 1,
                                                   AnalysisSet set = AnalysisSet::kAll);

// Adds to a published version what `set` asks for and it does not hold yet (`zoomwarp
// analyse`: eagerly, for a store ingested with less), on up to `threads` threads; what it holds is
// left as it is. Returns the names (derived_files.h stored_analyses) of what was added. Throws
// ModelFileError when the curator's warp.json is damaged, std::runtime_error when the pyramid
// cannot be read or the folder written.
std::vector<std::string> add_missing_analyses(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                              const SignificanceOptions& significance, AnalysisSet set,
                                              int threads = 1);

// Writes the model's files into `dir` (each to a temporary name, then renamed into place).
void write_image_model(const tiles::VersionFiles& files, const ImageModel& model);

// Reads them back; throws ModelFileError naming the first file that is missing or damaged.
ImageModel read_image_model(const tiles::ImageEntry& image);
SignificanceMap read_significance(const tiles::ImageEntry& image);

// How load_image_model got the model.
enum class ModelSource {
  kStored,         // all three files read intact
  kBuiltNoFiles,   // none of the files exist: a version published before models were stored
  kRebuiltWithEdits,  // a binary file was missing or damaged: rebuilt from the pyramid with warp.json
};

struct LoadedModel {
  ImageModel model;
  ModelSource source = ModelSource::kStored;
  std::string damaged_file;  // for kRebuiltWithEdits: which file, and why
  std::string reason;
  int unmeshable_suggestions = 0;  // lines=auto: suggestions left out because CGAL could not mesh them
};

// The model of a version, never silently without the curator's work: the stored files when
// intact; built from the pyramid when there are none; rebuilt from the pyramid with warp.json's
// lines and significance edits re-applied when a binary file is damaged. When warp.json itself
// is missing or damaged while other model files exist, the edits are lost and it throws
// ModelFileError for kModelJsonFile rather than serve a model without them.
//
// A variant other than the default is ICAZ driven by another saliency map (the same mesh and
// forest; the map and the node means are the kind's, from method_files.h saliency_map: a
// damaged gbvs.bin is computed again in memory and reported as kRebuiltWithEdits) or with
// another line set (line_set.h) than the stored curator's: for kAuto the detected lines added to
// the curator's — the suggestions not dismissed (detected_lines.h suggested_lines): the mesh
// follows their pieces within the curator's limits, minus any CGAL cannot mesh (auto_line_set),
// and the warp holds each of them whole (ImageModel::straight_lines) —, for kNone no lines; the
// mesh and forest are then rebuilt in memory (set_lines). kNone of a version without curator lines is
// the stored model itself.
struct ModelVariant {
  Saliency saliency = Saliency::kDefault;
  LineSet lines = LineSet::kCurator;
};
LoadedModel load_image_model(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                             const SignificanceOptions& significance = {}, const ModelVariant& variant = {});

// `model` (a version's model with the curator's lines, as load_image_model gives it for kCurator)
// with the line set `lines` instead: the same rebuild as load_image_model's, on a copy, so that a
// server derives every line set from the one model it read (a damaged file is rebuilt, and
// reported, once). kCurator gives the copy as it is.
LoadedModel with_line_set(ImageModel model, const tiles::ImageEntry& image, tiles::PyramidReader& reader, LineSet lines);

// An edit over one of warp/core/limits.h's limits; `limit` names which, as api/ reports it
// ("too_many_lines", "too_many_regions", "too_many_points", "too_many_stored_regions").
class LimitExceeded : public std::invalid_argument {
 public:
  LimitExceeded(std::string limit, const std::string& message)
      : std::invalid_argument(message), limit_(std::move(limit)) {}
  const std::string& limit() const { return limit_; }

 private:
  std::string limit_;
};

struct ModelEdit {
  std::optional<std::vector<Segment>> lines;      // replaces all line constraints
  std::optional<std::vector<Segment>> dismissed_lines;  // replaces the dismissed suggestions
  std::vector<SignificanceEdit> significance;     // painted in order
};

// Checks an edit: finite coordinates, lines (and dismissed lines) longer than a pixel, polygons of
// ≥ 3 points, weights in [0, 1], and the counts of warp/core/limits.h (lines, dismissed lines —
// at most as many as can be detected —, regions per edit, points per polygon). Throws std::invalid_argument. The limits that depend on the image (total line
// length, regions kept over all edits) are checked by api/edit_body.h and edit_image_model.
void validate(const ModelEdit& edit);

// Publishes a new version of `current`'s image with the edit applied to `model` (current's
// model; read from its files when not given). When the edit paints significance, the retargeting
// methods' files are precomputed again for every saliency kind `current` has them for (the others
// are hard links of `current`'s: their inputs did not change). Throws std::invalid_argument for a bad edit,
// LimitExceeded when the image would keep more than limits::kMaxStoredRegions regions, and
// tiles::VersionConflict if the image changed since `current` was read. Nothing is published
// when it throws.
std::shared_ptr<const tiles::ImageEntry> edit_image_model(tiles::Store& store, const tiles::ImageEntry& current,
                                                          const ModelEdit& edit, std::optional<ImageModel> model = {});

}  // namespace zoomwarp::warp
