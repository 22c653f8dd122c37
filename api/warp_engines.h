// One ICAZ operator (warp::Icaz) per image version and variant (saliency kind, automatic lines),
// and one Retargeter per (version, registered method, saliency kind), made from the model files
// kept with the image on first use and shared by every request for them: the forest and the
// caches per target size are what make panning cheap. Identical concurrent first uses load once
// (single flight). Their memory is bounded in bytes: engines are dropped least recently used
// first while the total is over the budget, and each engine's lazily grown forest is capped at a
// quarter of it. A new version (an edit, a re-ingest) is simply another key, so an old one's
// engine is never used for it.
//
// The model comes from warp::load_image_model: a damaged binary model file is rebuilt with the
// curator's lines and edits (a warning is logged); a damaged or missing warp.json while other
// model files exist makes the image's warp routes answer 500 "model_damaged" (an error is
// logged) — never a model without the curator's work. Failures are not cached: the next
// request tries again, so a repaired file is picked up without a restart (a failed load stops
// at warp.json and costs one small read).
//
// Thread safety: all members may be called concurrently; the engines returned are shared.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>
#include <variant>

#include "tiles/single_flight.h"
#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::api {

// Where the api reports events worth an operator's attention (the server's structured log).
using EventLog = std::function<void(std::string_view level, std::string_view msg, const nlohmann::json& fields)>;

class WarpEngines {
 public:
  // `significance` is used when a model has to be built from the pyramid; `log` may be empty.
  WarpEngines(tiles::PyramidReader& reader, std::size_t budget_bytes, warp::SignificanceOptions significance = {},
              EventLog log = {});

  // Throws ApiError(500, "model_damaged") if the curator's edits cannot be read, and
  // std::runtime_error if the model cannot be built.
  std::shared_ptr<warp::Icaz> get(const tiles::ImageEntry& image, warp::Saliency saliency = warp::Saliency::kDefault,
                                  bool auto_lines = false);

  // The registered method's engine for the version (its model file, or precomputed in memory
  // when the version has none). Throws as get() does.
  std::shared_ptr<warp::Retargeter> retargeter(const tiles::ImageEntry& image, const warp::RetargetingMethod& method,
                                               warp::Saliency saliency);

  // The engines' bytes as last measured, and how many there are (for /metrics).
  std::size_t memory_bytes();

 private:
  using Engine = std::variant<std::shared_ptr<warp::Icaz>, std::shared_ptr<warp::Retargeter>>;
  std::shared_ptr<warp::Icaz> load_icaz(const tiles::ImageEntry& image, warp::Saliency saliency, bool auto_lines);
  std::shared_ptr<warp::Retargeter> load_retargeter(const tiles::ImageEntry& image, const warp::RetargetingMethod& method,
                                                    warp::Saliency saliency);

  tiles::PyramidReader& reader_;
  std::size_t budget_;
  warp::SignificanceOptions significance_;
  EventLog log_;
  // The engines by key, loaded on first use, weighed in bytes after every use (they grow as views
  // visit them: lazy forest nodes, caches per target size).
  tiles::SingleFlight<Engine> engines_;
};

}  // namespace zoomwarp::api
