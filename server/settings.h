// Options shared by several subcommands, and how they turn into library settings.
#pragma once

#include <vector>

#include "server/options.h"
#include "tiles/ingest.h"

namespace zoomwarp::server {

// --store, --max-pixels, --tile-compression.
std::vector<OptionSpec> store_option_specs();
tiles::IngestOptions ingest_options(const Options& o);

}  // namespace zoomwarp::server
