// The retargeting methods' model files in an image version's folder (methods/retargeting_method.h):
//
//   <method>.<saliency>.bin   a method's precomputation for one saliency kind: a container
//                             magic, the method's magic, its bytes deflated (deflated_payload.h),
//                             the trailer of model_file.h (format 2; format 1, the method's
//                             magic and its bytes as they are, is still read)
//   <method>.<saliency>.curator-lines.bin, <method>.<saliency>.no-lines.bin
//                             the same for lines=curator and lines=none (line_set.h), for a
//                             method whose precomputation reads lines; the plain name is lines=auto
//
// A file whose method magic differs from the method's only in its digits (the format's version)
// was written by another release: it is precomputed again and replaced, as a missing one is.
//
// computed on first use and added to the published version (derived_files.h), or eagerly at
// ingest (write_image_analysis, AnalysisSet::kAll); an edit precomputes again those its version
// holds whose inputs changed. Each is written to a temporary name and renamed into place. A
// damaged file is rebuilt in memory: it is derived data, a pure function of the version's pixels
// and warp.json.
//
// Thread safety: free functions on immutable published folders; safe to call concurrently.
#pragma once

#include <cstddef>

#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/analysis/line_set.h"
#include "warp/analysis/model_file.h"
#include "warp/analysis/saliency_files.h"
#include "warp/icaz/image_model.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

// "<name>.<saliency>.bin", e.g. "seam.default.bin"; for a method that reads lines and a line set
// other than auto, "<name>.<saliency>.curator-lines.bin" or "<name>.<saliency>.no-lines.bin".
std::string method_file_name(const RetargetingMethod& method, Saliency saliency, LineSet lines = LineSet::kAuto);

// Thrown by method_payload for a file of the method's earlier format (see above).
class OutdatedMethodFile : public ModelFileError {
 public:
  using ModelFileError::ModelFileError;
};

// The method's precomputation in `bytes`, the whole file `file` of either format. Throws
// OutdatedMethodFile for an earlier format's file, ModelFileError(file, …) when the trailer, the
// magics or the compressed stream are wrong.
std::string method_payload(const std::string& file, std::string bytes, const RetargetingMethod& method);

// One method file: a registered method that keeps one (RetargetingMethod::precompute), for one
// saliency kind and line set (always kAuto for a method whose precomputation reads no lines).
struct MethodFile {
  const RetargetingMethod* method;
  Saliency saliency;
  LineSet lines = LineSet::kAuto;
};

// Which precomputations: every one, or only those that read lines (RetargetingMethod::
// reads_lines) — what an edit of the lines alone makes stale.
enum class MethodSelection { kAll, kReadingLines };

// The selected methods' files for each kind in `kinds` and the default line set (auto), in the
// registry's order, each method's kinds together.
std::vector<MethodFile> method_files(std::span<const Saliency> kinds, MethodSelection which = MethodSelection::kAll);

// The selected methods' files that `image` holds, of every line set (an edit precomputes again
// only those: issue 28, the others are made on first use).
std::vector<MethodFile> stored_method_files(const tiles::ImageEntry& image, MethodSelection which);

// Precomputes `files` and writes them into `to`; up to `threads` precomputations at once (they
// are independent) while their RetargetingMethod::precompute_bytes_per_pixel for the analysis
// image sum to at most `memory_budget` (tiles::run_jobs). Returns how long each took (for
// `zoomwarp ingest`'s report), in the order of `files`.
struct MethodFileTiming {
  std::string file;
  double seconds = 0;
};
std::vector<MethodFileTiming> write_method_files(const tiles::VersionFiles& to, const tiles::ImageEntry& image,
                                                 tiles::PyramidReader& reader, const ImageModel& model,
                                                 std::span<const MethodFile> files, int threads = 1,
                                                 std::size_t memory_budget = 0);

// How load_retargeter got the precomputation (kBuiltInMemory also for an outdated file).
enum class MethodSource { kStored, kNoFile, kBuiltInMemory, kRebuiltDamaged };

struct LoadedRetargeter {
  std::unique_ptr<Retargeter> engine;
  MethodSource source = MethodSource::kStored;
  std::string reason;  // for kRebuiltDamaged: the file and what was wrong with it
  bool stored = false;  // for kBuiltInMemory: the file was added to the version
};

// The method's Retargeter for a version and line set: from its file when intact, else
// precomputed — and, when the version has no file yet (issue 28: precomputed on first use) or
// one of an earlier format, the file added to it (derived_files.h) so that later loads read it; a
// damaged file is left as it is, for an operator to see, and precomputed in memory. `model` is
// the version's stored model (model.lines the curator's), except for a method that loads lines
// (RetargetingMethod::loads_lines), which gets the ICAZ model of the line set (ModelVariant).
// Throws std::runtime_error when the pyramid cannot be read.
LoadedRetargeter load_retargeter(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 const RetargetingMethod& method, Saliency saliency, LineSet lines = LineSet::kAuto);

}  // namespace zoomwarp::warp
