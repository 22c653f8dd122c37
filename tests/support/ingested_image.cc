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
  if (q.method == api::ViewMethod::kRetargeting) {
    const auto engine = engines.retargeter(e, *q.retargeting, q.saliency, q.lines);
    m.view = engine->view(q.view);
    if (q.from) m.morph = warp::Geomorph{m.view.source, {}, engine->view(*q.from).screen, m.view.screen};
    return m;
  }
  const auto icaz = engines.get(e, q.saliency, q.lines);
  if (q.method == api::ViewMethod::kTraditional) {
    m.view = icaz->traditional(q.view);
    if (q.from) m.morph = warp::Geomorph{m.view.source, {}, icaz->traditional(*q.from).screen, m.view.screen};
  } else if (q.from) {
    m.morph = icaz->geomorph(*q.from, q.view, &m.view);
  } else {
    m.view = icaz->view(q.view);
  }
  return m;
}

}  // namespace zoomwarp::testing
