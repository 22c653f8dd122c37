#include "tiles/ingest.h"

#include <filesystem>
#include <stdexcept>

#include "tiles/image_id.h"
#include "tiles/store_errors.h"

namespace zoomwarp::tiles {

namespace {
// Carries from the version published now into `staging` and publishes on that version
// (IngestOptions::carry); an edit published meanwhile is a conflict, and the next try builds on
// the version that lost (its pyramid and analyses) with the newer one's files carried.
Manifest publish_carrying(Store& store, std::string staging, const Manifest& m, const IngestOptions& options) {
  for (int attempt = 1;; ++attempt) {
    const std::shared_ptr<const ImageEntry> published = store.find_now(m.id);
    const std::string expected = published ? published->manifest.version : "";
    try {
      if (options.carry) options.carry(published.get(), *folder_files(staging));
    } catch (...) {
      store.discard(staging);
      throw;
    }
    try {
      return store.publish(staging, m, &expected)->manifest;
    } catch (const VersionConflict& conflict) {
      if (attempt == kCarryAttempts || !conflict.stored) throw;
      staging = store.make_staging_copy(*conflict.stored);
    }
  }
}
}  // namespace

Manifest ingest_image(Store& store, const std::string& source_path, const std::string& id,
                      const IngestOptions& options, const ProgressFn& progress) {
  if (!is_valid_image_id(id)) throw std::invalid_argument("invalid image id");
  const std::string staging = store.make_staging_dir();
  try {
    // With an analysis, the pyramid's progress runs to 0.95 and the analysis's step follows.
    const double pyramid_share = options.analyse ? 0.95 : 1.0;
    ProgressFn pyramid_progress;
    if (progress) pyramid_progress = [&](double f) { progress(pyramid_share * f); };
    PyramidInfo info = build_pyramid(source_path, staging, options.pyramid, options.limits, pyramid_progress);
    Manifest m;
    m.id = id;
    m.width = info.width;
    m.height = info.height;
    m.channels = info.channels;
    m.levels = info.levels;
    m.tile_size = options.pyramid.tile_size;
    m.compression = info.compression.method;
    if (m.compression == "jpeg") m.jpeg = info.compression.jpeg;
    m.is_private = options.is_private;
    m.source_format = info.source_format;
    m.source_bits = info.source_bits;
    m.source_channels = info.source_channels;
    m.source_orientation = info.source_orientation;
    std::error_code ec;
    m.source_bytes = std::int64_t(std::filesystem::file_size(source_path, ec));
    m.source_sha256 = options.source_sha256;
    if (options.analyse) {
      options.analyse(ImageEntry{m, folder_files(staging)});
      if (progress) progress(0.99);
    }
    Manifest published = publish_carrying(store, staging, m, options);
    if (progress) progress(1.0);
    return published;
  } catch (const IngestError&) {
    store.discard(staging);
    throw;
  } catch (const StoreUnavailable&) {  // the store's failure, not the image's: 503/504, not 500
    store.discard(staging);
    throw;
  } catch (const VersionConflict&) {
    store.discard(staging);
    throw;
  } catch (const std::exception& e) {
    store.discard(staging);
    throw IngestError(IngestError::Kind::kIo, e.what());
  }
}

}  // namespace zoomwarp::tiles
