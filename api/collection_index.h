// The public images and their descriptions, as the IIIF collection and its pages list them
// (issue 42): made once per state of the store, not on every page. Each page used to read every
// manifest and up to 100 descriptions, and one damaged description made the whole page a 500.
//
// The index is made again when this process has published or removed an image since it was made
// (Store::generation), or once it is older than the store's recheck interval (another replica's
// changes, which this process sees within that interval anyway). A description that cannot be
// read or parsed is logged and left out: its image is listed, with its id as its only label.
//
// Threads: current() may be called from any thread; one of them makes a new index while callers
// meanwhile wait for it, and every caller then shares it.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <vector>

#include "api/description.h"
#include "api/warp_engines.h"
#include "tiles/store.h"

namespace zoomwarp::api {

class CollectionIndex {
 public:
  struct Listed {
    std::shared_ptr<const tiles::ImageEntry> image;
    Description description;  // empty when the image has none, or a damaged one
  };

  CollectionIndex(tiles::Store& store, EventLog log);

  // The public images, sorted by id, as of the store's state now (see above).
  std::shared_ptr<const std::vector<Listed>> current();

 private:
  tiles::Store& store_;
  const EventLog log_;
  std::mutex mu_;
  std::shared_ptr<const std::vector<Listed>> index_;
  std::uint64_t generation_ = 0;
  std::chrono::steady_clock::time_point made_at_{};
};

}  // namespace zoomwarp::api
