// An image ingested into a temporary store (or one already in a store), with the warp engines the
// server makes for it: the api's views without a server (unit tests, benchmarks). Not thread-safe to construct; the
// engines are (api/warp_engines.h).
#pragma once

#include <memory>
#include <optional>
#include <string>

#include "api/view_query.h"
#include "api/warp_engines.h"
#include "tests/support/server_process.h"
#include "tiles/pyramid_reader.h"
#include "tiles/store.h"

namespace zoomwarp::testing {

struct IngestedImage {
  // Ingests `path` (default ingest options) as image `id`; throws what the ingest throws.
  IngestedImage(const std::string& path, const std::string& id);
  // Image `id` of the existing store at `store_dir`, read only (e.g. the store a benchmark's server
  // serves); throws std::runtime_error if the store has no such image.
  struct InStore {
    std::string store_dir;
  };
  IngestedImage(const InStore& in, const std::string& id);

  // What /mesh draws for a query string (api/view_query.h): the view, and with from_* the
  // geomorph pair, as router_views.cc makes them (ICAZ's common refinement, every other method's
  // vertex-by-vertex pair). Throws what parsing and the engines throw.
  struct MeshViews {
    api::ViewQuery query;
    warp::View view;
    std::optional<warp::Geomorph> morph;
  };
  MeshViews mesh_views(const std::string& query);

  TempDir dir;
  tiles::Store store{dir.path() + "/store"};
  tiles::PyramidReader reader{64u << 20};
  api::WarpEngines engines{reader, {.budget_bytes = 512u << 20}};
  std::shared_ptr<const tiles::ImageEntry> entry;
};

}  // namespace zoomwarp::testing
