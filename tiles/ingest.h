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

struct IngestOptions {
  PyramidOptions pyramid;
  SourceLimits limits;
  // Runs on the finished pyramid before it is published (e.g. the warp engine's analysis); what
  // it writes into the entry's folder is published with the image. Throwing fails the ingest.
  // The entry's manifest has no version yet.
  std::function<void(const ImageEntry& staged)> analyse;
  bool is_private = false;  // Manifest::is_private of the published version
  // Files of the id's published version, if there is one, copied into the new version unless it
  // has them already (an upload that gives its own): the curator's data that does not depend on
  // the pixels (api/description.h), which a re-ingest must not drop. Copied after `analyse`.
  std::vector<std::string> carried_files;
  // Manifest::source_sha256 of the published version: the source file's digest when the caller
  // has it (file_sha256_hex, `zoomwarp ingest`), empty when not.
  std::string source_sha256;
};

// Throws IngestError (bad input or write failure) or std::invalid_argument (invalid id).
Manifest ingest_image(Store& store, const std::string& source_path, const std::string& id,
                      const IngestOptions& options, const ProgressFn& progress = {});

}  // namespace zoomwarp::tiles
