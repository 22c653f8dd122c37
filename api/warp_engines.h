// One ICAZ operator (warp::Icaz) per image version and variant (saliency kind, automatic lines),
// and one Retargeter per (version, registered method, saliency kind), made from the model files
// kept with the image on first use and shared by every request for them: the forest and the
// caches per target size are what make panning cheap. Their memory is bounded in bytes: engines
// are dropped least recently used first while the total is over the budget, and each engine's
// lazily grown forest is capped at a quarter of it. A new version (an edit, a re-ingest) is
// simply another key, so an old one's engine is never used for it.
//
// Work shared by many requests runs in the background (issue 28): loading an engine — which, for
// a version not analysed yet, computes its analysis and adds it to the version's folder
// (warp/analysis/derived_files.h) — and a method's warp for a new screen size run once per key on
// `analysis_threads` threads below request priority (tiles/background_flights.h), to completion,
// whatever happens to the request that asked first. A request waits for them as long as its
// StopToken allows: past its deadline it gets ApiError 503 "analysis_pending" with Retry-After
// and its retry finds the work done; a request whose client left stops waiting, the work goes on.
// Failures are not kept: the next request tries again.
//
// The model comes from warp::load_image_model: a damaged binary model file is rebuilt with the
// curator's lines and edits (a warning is logged); a damaged or missing warp.json while other
// model files exist makes the image's warp routes answer 500 "model_damaged" (an error is
// logged) — never a model without the curator's work. A repaired file is picked up without a
// restart (a failed load stops at warp.json and costs one small read).
//
// Thread safety: all members may be called concurrently; the engines returned are shared.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <string_view>
#include <unordered_set>
#include <variant>

#include "api/view_methods.h"
#include "tiles/background_flights.h"
#include "tiles/pyramid_reader.h"
#include "tiles/single_flight.h"
#include "tiles/store.h"
#include "warp/analysis/line_set.h"
#include "warp/core/stop_token.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retargeting_method.h"

namespace zoomwarp::api {

// Where the api reports events worth an operator's attention (the server's structured log).
using EventLog = std::function<void(std::string_view level, std::string_view msg, const nlohmann::json& fields)>;

struct WarpEngineOptions {
  std::size_t budget_bytes = 256u << 20;  // engines kept in memory
  warp::SignificanceOptions significance;  // for models built from the pyramid (the face cascade)
  int analysis_threads = 1;                // background threads (analyses, warps for a new screen)
  std::size_t max_pending = 64;            // background computations queued or running; more: 503
};

class WarpEngines {
 public:
  WarpEngines(tiles::PyramidReader& reader, WarpEngineOptions options, EventLog log = {});

  // The ICAZ operator of the version and variant (saliency kind, line set: by default the curator's
  // and the detected lines, warp/analysis/line_set.h). Throws ApiError(500, "model_damaged") if the
  // curator's edits cannot be read, ApiError(503, "analysis_pending") when `stop`'s deadline
  // passes while its analysis is computed, warp::Stopped(kCancelled) when `stop` is cancelled
  // meanwhile, and std::runtime_error if the model cannot be built.
  std::shared_ptr<warp::Icaz> get(const tiles::ImageEntry& image, warp::Saliency saliency = warp::Saliency::kDefault,
                                  warp::LineSet lines = warp::LineSet::kAuto, const warp::StopToken* stop = nullptr);

  // The registered method's engine for the version and line set (its model file, or precomputed
  // and added to the version). Throws as get() does.
  std::shared_ptr<warp::Retargeter> retargeter(const tiles::ImageEntry& image, const warp::RetargetingMethod& method,
                                               warp::Saliency saliency, warp::LineSet lines = warp::LineSet::kAuto,
                                               const warp::StopToken* stop = nullptr);

  // The same, with its warp for a `screen_width`×`screen_height` screen computed (in the
  // background: every view of that screen shares it). Throws as get() does.
  // `frame` is the views' (warp/window/fit.h): their warp's target aspect at zoom 0.
  std::shared_ptr<warp::Retargeter> retargeter_for_screen(const tiles::ImageEntry& image,
                                                          const warp::RetargetingMethod& method, warp::Saliency saliency,
                                                          warp::LineSet lines, int screen_width, int screen_height,
                                                          const warp::StopToken* stop = nullptr,
                                                          warp::ZoomFrame frame = {});

  // What draws `method`'s views of the version (api/view_methods.h), so that routes and tools
  // never ask which method they hold: api's own through the version's shared ICAZ operator
  // (get(), wrapped by warp/methods/icaz_retargeter.h; traditional zoom reads no saliency map), a
  // registered one as retargeter() — or, given a screen (both sides > 0), as
  // retargeter_for_screen(), its warp for that screen (and frame) made first. Throws as get() does.
  std::shared_ptr<warp::Retargeter> view_engine(const tiles::ImageEntry& image, const ViewMethod& method,
                                                warp::Saliency saliency, warp::LineSet lines,
                                                const warp::StopToken* stop = nullptr, int screen_width = 0,
                                                int screen_height = 0, warp::ZoomFrame frame = {});

  // The engines' bytes as last measured (for /metrics).
  std::size_t memory_bytes();

  // For /metrics: analyses computed here (no file yet, or a damaged one) and read from the
  // version's files; background computations queued or running.
  struct Counts {
    std::uint64_t computed = 0, read = 0;
    std::size_t pending = 0;
  };
  Counts counts() const;

 private:
  using Engine = std::variant<std::shared_ptr<warp::Icaz>, std::shared_ptr<warp::Retargeter>>;

  // The engine under `key`: kept, or loaded in the background while `stop` allows.
  Engine engine(const std::string& key, std::function<Engine()> load, const warp::StopToken* stop);
  // Waits for a background flight as long as `stop` allows (see get()).
  Engine await(const tiles::BackgroundFlights<Engine>::Future& flight, const warp::StopToken* stop);
  // On a background thread: an ICAZ engine — the default-saliency one of a line set, whose model
  // every method reads; the curator's one of a kind, which the other line sets derive from —
  // loaded here (waiting for another background flight from a background thread could wait for
  // itself).
  std::shared_ptr<warp::Icaz> icaz_now(const tiles::ImageEntry& image, warp::Saliency saliency, warp::LineSet lines);
  std::shared_ptr<warp::Icaz> load_icaz(const tiles::ImageEntry& image, warp::Saliency saliency, warp::LineSet lines);
  std::shared_ptr<warp::Retargeter> load_retargeter(const tiles::ImageEntry& image, const warp::RetargetingMethod& method,
                                                    warp::Saliency saliency, warp::LineSet lines);

  tiles::PyramidReader& reader_;
  const WarpEngineOptions options_;
  EventLog log_;
  std::atomic<std::uint64_t> computed_{0}, read_{0};
  // The engines by key, loaded on first use, weighed in bytes after every use (they grow as views
  // visit them: lazy forest nodes, caches per target size).
  tiles::SingleFlight<Engine> engines_;
  // Retargeters (by address) whose warp for a screen size has been computed, "ptr|WxH"; cleared
  // when it grows past a bound (a cleared entry costs one cheap background round trip).
  std::mutex warmed_mu_;
  std::unordered_set<std::string> warmed_;
  // Last: its threads use the members above, and its destructor joins them first.
  tiles::BackgroundFlights<Engine> background_;
};

}  // namespace zoomwarp::api
