#include "tests/support/ingested_image.h"

#include <stdexcept>

#include "tiles/ingest.h"

namespace zoomwarp::testing {

IngestedImage::IngestedImage(const std::string& path, const std::string& id) {
  tiles::ingest_image(store, path, id, {});
  entry = store.find(id);
}

IngestedImage::IngestedImage(const InStore& in, const std::string& id) : store(in.store_dir), entry(store.find(id)) {
  if (!entry) throw std::runtime_error("no image '" + id + "' in the store at " + in.store_dir);
}

IngestedImage::MeshViews IngestedImage::mesh_views(const std::string& query) {
  const tiles::ImageEntry& e = *entry;
  MeshViews m{api::parse_view_query(query, api::ViewRoute::kMesh, e.manifest.width, e.manifest.height), {}, {}};
  const api::ViewQuery& q = m.query;
  // As the /mesh route draws it: whatever the method, through its Retargeter.
  const auto engine = engines.view_engine(e, *q.method, q.saliency, q.lines);
  if (q.from) m.morph = engine->geomorph(*q.from, q.view, &m.view);
  else m.view = engine->view(q.view);
  return m;
}

}  // namespace zoomwarp::testing
