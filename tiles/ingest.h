// Ingest as one operation: decode, build the pyramid in a staging folder, publish atomically.
// On any failure nothing is left in the store and the previously published version (if any)
// stays in place.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include "tiles/manifest.h"
#include "tiles/pyramid_builder.h"
#include "tiles/store.h"

namespace zoomwarp::tiles {

// How often an ingest carries the curator's files over and tries to publish before it gives up
// (VersionConflict): each try loses only to an edit published during the previous one.
inline constexpr int kCarryAttempts = 4;

struct IngestOptions {
  PyramidOptions pyramid;
  SourceLimits limits;
  // Runs on the finished pyramid before it is published (e.g. the warp engine's analysis); what
  // it writes into the entry's folder is published with the image. Throwing fails the ingest.
  // The entry's manifest has no version yet.
  std::function<void(const ImageEntry& staged)> analyse;
  bool is_private = false;  // Manifest::is_private of the published version
  // What the new version takes from the id's published version (null when there is none),
  // written into the staged version: the curator's data that does not depend on the pixels
  // (api/description.h), which a re-ingest must not drop. Run last, on the version published at
  // that moment (read from the store, not remembered), and the publish is conditional on it: when
  // an edit or another ingest is published in between, by this process or another replica, it
  // runs again on the newer version (up to kCarryAttempts in all), so an edit made during an
  // ingest is kept. Whatever it writes must depend on `published` only (it may run again).
  std::function<void(const ImageEntry* published, const VersionFiles& staged)> carry;
  // Manifest::source_sha256 of the published version: the source file's digest when the caller
  // has it (file_sha256_hex, `zoomwarp ingest`), empty when not.
  std::string source_sha256;
};

// Throws IngestError (bad input or write failure), std::invalid_argument (invalid id),
// StoreUnavailable, or VersionConflict (edited kCarryAttempts times while it published).
Manifest ingest_image(Store& store, const std::string& source_path, const std::string& id,
                      const IngestOptions& options, const ProgressFn& progress = {});

}  // namespace zoomwarp::tiles
