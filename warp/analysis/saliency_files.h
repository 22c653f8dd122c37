// The saliency maps' files in an image version's folder, and a version's map of either kind:
//
//   significance.bin   the default map (image_analysis.h writes it with the model)
//   gbvs.bin           the GBVS map (saliency=gbvs, ≤ 1024 px, floats), faces painted in but not
//                      the curator's edits: they are painted when it is loaded, so an edit's new
//                      version keeps it as a hard link
//
// Both have one layout: magic, the map, the model_file.h trailer. The map is written compact
// (format 3, compact_map.h: one byte per value, predicted and deflated); the float maps of
// formats 1 (significance.bin without the trailer) and 2 — width, height, scale, a float per
// value — are still read.
//
// Thread safety: free functions on immutable published folders; safe to call concurrently.
#pragma once

#include <string>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/analysis/model_file.h"
#include "warp/icaz/image_model.h"
#include "warp/saliency/saliency.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

inline constexpr const char* kGbvsFile = "gbvs.bin";

// A map file kind's magic per format (a kind that never had format 1 names format 2's twice).
struct SaliencyFileMagics {
  Magic floats_untrailed;  // format 1
  Magic floats;            // format 2
  Magic compact;           // format 3, written
};

// A map file's bytes (format 3, trailer included), and a map file of any format read back and
// checked against the image's size; throws ModelFileError naming `file`.
std::string saliency_map_bytes(const SignificanceMap& map, const SaliencyFileMagics& magics);
SignificanceMap read_saliency_map_file(const tiles::ImageEntry& image, const char* file,
                                       const SaliencyFileMagics& magics);

// gbvs.bin. read_gbvs_map throws ModelFileError.
void write_gbvs_map(const tiles::VersionFiles& files, const SignificanceMap& map);
SignificanceMap read_gbvs_map(const tiles::ImageEntry& image);

// The saliency map of kind `kind` of the version whose model is `model`, with faces and the
// curator's edits (model.edits) painted in: `default` is model.significance; `gbvs` is gbvs.bin
// (above) when intact, else GBVS of the analysis image computed in memory, faces found
// with `significance`'s cascade — never written into the published version. `damaged` says what
// was wrong with a gbvs.bin that exists but could not be used (empty otherwise: a version ingested
// before GBVS has none, which is not damage). Throws std::runtime_error when the pyramid cannot
// be read.
struct LoadedSaliency {
  SignificanceMap map;
  std::string damaged;
};
LoadedSaliency load_saliency_map(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 Saliency kind, const SignificanceOptions& significance = {});
SignificanceMap saliency_map(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                             Saliency kind, const SignificanceOptions& significance = {});

}  // namespace zoomwarp::warp
