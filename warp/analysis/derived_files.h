// Analyses computed on first use and kept with the image version they were computed for (issue
// 28): an ingest publishes the pyramid alone (unless asked for more, see image_analysis.h
// AnalysisSet), and each analysis — ICAZ's model, the GBVS map, the detected lines, a method's
// precomputation for one saliency kind — is computed the first time a view needs it and added to
// the published version's folder. Other replicas and later processes then read it instead of
// computing it again.
//
// That a published version gains files does not break its immutability as readers see it: every
// such file is derived data, a pure function of the version's pixels and warp.json (the curator's
// work, which is written at ingest or by the edit that made the version and never added later),
// so whichever writer's bytes land, a reader computes the same views. Each file is written under
// a temporary name of its writer's own and renamed into place (tiles::VersionFiles::write), so
// two replicas computing one analysis at once, and their readers, never meet a partial file.
//
// Thread safety: free functions on published folders; safe to call concurrently, also from
// several processes.
#pragma once

#include <string>
#include <vector>

#include "tiles/store.h"

namespace zoomwarp::warp {

// Adds `file` with `bytes` to a published version's folder. Returns false and leaves nothing
// behind when the folder cannot be written (a read-only store, a version the garbage collector
// removed meanwhile): the caller keeps what it computed in memory and serves from that.
bool add_derived_file(const tiles::ImageEntry& image, const char* file, const std::string& bytes);

// The analyses a version holds, by the names GET /v1/images/{id} lists them under:
//   "icaz.default"        ICAZ's model (significance.bin, warp_model.bin with warp.json)
//   "icaz.gbvs"           ICAZ's model and the GBVS map (gbvs.bin)
//   "lines"               the detected straight edges (lines.detected.json)
//   "<method>.<saliency>" a registered method's precomputation (methods/retargeting_method.h)
//   "<method>.<saliency>.curator", "<method>.<saliency>.none"
//                         the same for lines=curator and lines=none (method_files.h)
// Reads only whether the files exist, not whether they are intact.
std::vector<std::string> stored_analyses(const tiles::ImageEntry& image);

}  // namespace zoomwarp::warp
