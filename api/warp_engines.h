// One ICAZ operator (warp::Icaz) per image version, made from the model files kept with the
// image on first use and shared by every request for that version: its forest and its coarse-warp
// cache (per target size) are what make panning cheap. Identical concurrent first uses load once
// (single flight). Their memory is bounded in bytes: engines are dropped least recently used
// first while the total is over the budget, and each engine's lazily grown forest is capped at a
// quarter of it. A new version (an edit, a re-ingest) is simply another key, so an old one's
// engine is never used for it.
#pragma once

#include <cstddef>
#include <future>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/icaz.h"

namespace zoomwarp::api {

class WarpEngines {
 public:
  WarpEngines(tiles::PyramidReader& reader, std::size_t budget_bytes);

  // Throws std::runtime_error if the model cannot be read or built.
  std::shared_ptr<warp::Icaz> get(const tiles::ImageEntry& image);

  // The engines' bytes as last measured, and how many there are (for /metrics).
  std::size_t memory_bytes();

 private:
  using Future = std::shared_future<std::shared_ptr<warp::Icaz>>;
  std::shared_ptr<warp::Icaz> load(const tiles::ImageEntry& image);

  void evict_over_budget(const std::string& keep);

  tiles::PyramidReader& reader_;
  std::size_t budget_;
  std::mutex mu_;
  std::list<std::string> order_;  // most recently used first
  struct Entry {
    Future engine;
    std::list<std::string>::iterator position;
    std::size_t bytes = 0;  // as last measured
  };
  std::unordered_map<std::string, Entry> engines_;
};

}  // namespace zoomwarp::api
