// Options shared by several subcommands, and how they turn into library settings.
#pragma once

#include <string>
#include <vector>

#include "server/options.h"
#include "tiles/ingest.h"
#include "tiles/store.h"
#include "warp/analysis/method_files.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::server {

// --store, --max-pixels, --tile-compression, --ingest-threads, --face-cascade.
std::vector<OptionSpec> store_option_specs();

// --store-cache, --store-cache-bytes, --store-memory-bytes: what a bucket store keeps locally.
std::vector<OptionSpec> bucket_store_option_specs();
tiles::BucketStoreOptions bucket_store_options(const Options& o);

// The warp engine's analysis settings: --face-cascade found (warp::find_face_cascade), and face
// detection's state for /readyz: "on", or "off: " and why. Logs a warning when it is off.
struct AnalysisSettings {
  warp::SignificanceOptions significance;
  std::string face_detection;
};
AnalysisSettings analysis_settings(const Options& o);

// The ingest options (pyramid and warp analysis on --ingest-threads threads); the warp analysis
// hook stores each method file's precompute time in `*method_timings` when given (`zoomwarp
// ingest` prints them).
tiles::IngestOptions ingest_options(const Options& o, const warp::SignificanceOptions& significance,
                                    std::vector<warp::MethodFileTiming>* method_timings = nullptr);

}  // namespace zoomwarp::server
