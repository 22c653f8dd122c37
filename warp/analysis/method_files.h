// The retargeting methods' model files in an image version's folder (methods/retargeting_method.h):
//
//   <method>.<saliency>.bin   a method's precomputation for one saliency kind: a container
//                             magic, the method's magic, its bytes deflated (deflated_payload.h),
//                             the trailer of model_file.h (format 2; format 1, the method's
//                             magic and its bytes as they are, is still read)
//
// written at ingest (write_image_analysis) and by edits whose inputs changed, each to a temporary
// name and renamed into place. A version without a method's file (ingested before the method
// existed) gets the precomputation built in memory on first use — never written into a
// published version. A damaged file is rebuilt in memory the same way: it is derived data, a pure
// function of the version's pixels and warp.json.
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
#include "warp/analysis/saliency_files.h"
#include "warp/icaz/image_model.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::warp {

// "<name>.<saliency>.bin", e.g. "seam.default.bin".
std::string method_file_name(const RetargetingMethod& method, Saliency saliency);

// The method's precomputation in `bytes`, the whole file `file` of either format. Throws
// ModelFileError(file, …) when the trailer, the magics or the compressed stream are wrong.
std::string method_payload(const std::string& file, std::string bytes, const RetargetingMethod& method);

// Precomputes every registered method that keeps a file (kReadingLines: only those whose
// precomputation reads lines — what an edit of the lines alone makes stale), for each kind in
// `kinds`, and writes the files into `dir`; up to `threads` precomputations at once (they are
// independent) while their RetargetingMethod::precompute_bytes_per_pixel for the analysis image
// sum to at most `memory_budget` (tiles::run_jobs). Returns how long each took (for `zoomwarp ingest`'s report), for each
// method in the registry's order each kind in `kinds`.
struct MethodFileTiming {
  std::string file;
  double seconds = 0;
};
enum class MethodSelection { kAll, kReadingLines };
std::vector<MethodFileTiming> write_method_files(const std::string& dir, const tiles::ImageEntry& image,
                                                 tiles::PyramidReader& reader, const ImageModel& model,
                                                 std::span<const Saliency> kinds,
                                                 MethodSelection which = MethodSelection::kAll, int threads = 1,
                                                 std::size_t memory_budget = 0);

// How load_retargeter got the precomputation.
enum class MethodSource { kStored, kNoFile, kBuiltInMemory, kRebuiltDamaged };

struct LoadedRetargeter {
  std::unique_ptr<Retargeter> engine;
  MethodSource source = MethodSource::kStored;
  std::string reason;  // for kRebuiltDamaged: the file and what was wrong with it
};

// The method's Retargeter for a version: from its file when intact, else precomputed in memory.
// Throws std::runtime_error when the pyramid cannot be read.
LoadedRetargeter load_retargeter(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 const RetargetingMethod& method, Saliency saliency);

}  // namespace zoomwarp::warp
