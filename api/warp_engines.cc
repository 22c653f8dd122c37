#include "api/warp_engines.h"

#include <algorithm>
#include <chrono>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"

namespace zoomwarp::api {

namespace {

// How long a client is told to wait before retrying a view whose analysis is being computed:
// most analyses of a ≤ 1024 px analysis image take about a second.
constexpr int kRetryAfterSeconds = 1;
constexpr std::size_t kMaxWarmed = 4096;

std::string icaz_key(const tiles::ImageEntry& image, warp::Saliency saliency, warp::LineSet lines) {
  return image.files->location() + "|icaz|" + std::string(warp::saliency_name(saliency)) + "|" +
         std::string(warp::line_set_name(lines));
}

}  // namespace

WarpEngines::WarpEngines(tiles::PyramidReader& reader, WarpEngineOptions options, EventLog log)
    : reader_(reader),
      options_(std::move(options)),
      log_(std::move(log)),
      engines_(options_.budget_bytes,
               [](const Engine& e) { return std::visit([](const auto& p) { return p->memory_bytes(); }, e); }),
      background_(options_.analysis_threads, options_.max_pending) {}

std::shared_ptr<warp::Icaz> WarpEngines::load_icaz(const tiles::ImageEntry& image, warp::Saliency saliency,
                                                   warp::LineSet lines) {
  const std::string& id = image.manifest.id;
  warp::LoadedModel loaded;
  try {
    // Another line set than the curator's is derived from the curator's engine of the same kind,
    // so that the version's files are read — and a damaged one rebuilt and reported — once.
    if (lines != warp::LineSet::kCurator)
      loaded = warp::with_line_set(icaz_now(image, saliency, warp::LineSet::kCurator)->model(), image, reader_, lines);
    else
      loaded = warp::load_image_model(image, reader_, options_.significance, {saliency, lines});
  } catch (const warp::ModelFileError& e) {
    if (log_)
      log_("error", "warp model damaged, curator edits unreadable",
           {{"image", id}, {"version", image.manifest.version}, {"file", e.file()}, {"error", e.what()}});
    throw ApiError(500, "model_damaged",
                   "the warp model of image '" + id +
                       "' is damaged and its curator edits (lines, significance) cannot be read; its tiles still "
                       "work; an operator must restore the model files or re-ingest the image");
  }
  (loaded.source == warp::ModelSource::kStored ? read_ : computed_)++;
  if (loaded.source == warp::ModelSource::kRebuiltWithEdits && log_)
    log_("warn", "warp model file damaged, rebuilt with the curator's lines and edits",
         {{"image", id}, {"version", image.manifest.version}, {"file", loaded.damaged_file}, {"error", loaded.reason}});
  if (loaded.source == warp::ModelSource::kBuiltNoFiles && log_)
    log_("info", "warp model computed on first use",
         {{"image", id}, {"version", image.manifest.version}, {"saliency", warp::saliency_name(saliency)}});
  if (loaded.unmeshable_suggestions > 0 && log_)
    log_("info", "lines=auto: detected lines left out, the coarsest mesh cannot be built with them",
         {{"image", id}, {"version", image.manifest.version}, {"left_out", loaded.unmeshable_suggestions}});
  warp::ImageModel& model = loaded.model;
  warp::IcazOptions icaz;
  constexpr std::size_t kBytesPerLazyNode = 64;
  icaz.max_forest_nodes =
      int(std::clamp<std::size_t>(model.forest.kept_nodes() + options_.budget_bytes / 4 / kBytesPerLazyNode,
                                  model.forest.kept_nodes() + 10000, 1u << 22));
  return std::make_shared<warp::Icaz>(std::move(model), icaz);
}

std::shared_ptr<warp::Retargeter> WarpEngines::load_retargeter(const tiles::ImageEntry& image,
                                                               const warp::RetargetingMethod& method,
                                                               warp::Saliency saliency, warp::LineSet lines) {
  // Every method reads the version's model (size, lines, significance): a default-saliency ICAZ
  // engine's, loaded once and shared — the stored one (the curator's lines), or the line set's
  // for a method that loads its lines (method_files.h load_retargeter).
  const auto icaz = icaz_now(image, warp::Saliency::kDefault, method.loads_lines ? lines : warp::LineSet::kCurator);
  warp::LoadedRetargeter loaded = warp::load_retargeter(image, reader_, icaz->model(), method, saliency, lines);
  (loaded.source == warp::MethodSource::kStored || loaded.source == warp::MethodSource::kNoFile ? read_ : computed_)++;
  const nlohmann::json fields = {{"image", image.manifest.id},
                                 {"version", image.manifest.version},
                                 {"method", method.name},
                                 {"saliency", warp::saliency_name(saliency)},
                                 {"lines", warp::line_set_name(lines)}};
  if (loaded.source == warp::MethodSource::kRebuiltDamaged && log_) {
    nlohmann::json f = fields;
    f["error"] = loaded.reason;
    log_("warn", "method model file damaged, precomputed again in memory", f);
  }
  if (loaded.source == warp::MethodSource::kBuiltInMemory && log_)
    log_(loaded.stored ? "info" : "warn",
         loaded.stored ? "method analysis computed on first use and stored with the image"
                       : "method analysis computed on first use but could not be stored: kept in memory only",
         fields);
  return std::move(loaded.engine);
}

std::shared_ptr<warp::Icaz> WarpEngines::icaz_now(const tiles::ImageEntry& image, warp::Saliency saliency,
                                                  warp::LineSet lines) {
  const std::string key = icaz_key(image, saliency, lines);
  return std::get<std::shared_ptr<warp::Icaz>>(
      engines_.get(key, [&] { return Engine(load_icaz(image, saliency, lines)); }).value);
}

WarpEngines::Engine WarpEngines::await(const tiles::BackgroundFlights<Engine>::Future& flight,
                                       const warp::StopToken* stop) {
  if (stop)
    while (flight.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) {
      if (!stop->stop_requested()) continue;
      try {
        stop->check();
      } catch (const warp::Stopped& stopped) {
        if (stopped.reason() == warp::Stopped::Reason::kCancelled) throw;
      }
      // Out of time, not failed: the work goes on, and the retry finds it done. Not a deadline
      // failure, which the router's failure cache would answer the retry with.
      throw ApiError(503, "analysis_pending",
                     "this image's analysis for the method asked for is being computed (first use); retry shortly")
          .with_retry_after(kRetryAfterSeconds);
    }
  return flight.get();  // rethrows what the loading threw
}

WarpEngines::Engine WarpEngines::engine(const std::string& key, std::function<Engine()> load,
                                        const warp::StopToken* stop) {
  if (auto kept = engines_.find(key)) return *kept;
  tiles::BackgroundFlights<Engine>::Future flight;
  try {
    flight = background_.run(key, [this, key, load = std::move(load)] { return engines_.get(key, load).value; });
  } catch (const tiles::BackgroundFlights<Engine>::Busy& busy) {
    throw ApiError(503, "busy", std::string(busy.what()) + "; retry shortly").with_retry_after(kRetryAfterSeconds);
  }
  return await(flight, stop);
}

std::shared_ptr<warp::Icaz> WarpEngines::get(const tiles::ImageEntry& image, warp::Saliency saliency,
                                             warp::LineSet lines, const warp::StopToken* stop) {
  return std::get<std::shared_ptr<warp::Icaz>>(engine(
      icaz_key(image, saliency, lines), [this, image, saliency, lines] { return Engine(load_icaz(image, saliency, lines)); },
      stop));
}

namespace {
std::string retargeter_key(const tiles::ImageEntry& image, const warp::RetargetingMethod& method,
                           warp::Saliency saliency, warp::LineSet lines) {
  return image.files->location() + "|" + std::string(method.name) + "|" + std::string(warp::saliency_name(saliency)) +
         "|" + std::string(warp::line_set_name(method.lines.empty() ? warp::LineSet::kCurator : lines));
}
}  // namespace

std::shared_ptr<warp::Retargeter> WarpEngines::retargeter(const tiles::ImageEntry& image,
                                                          const warp::RetargetingMethod& method,
                                                          warp::Saliency saliency, warp::LineSet lines,
                                                          const warp::StopToken* stop) {
  return std::get<std::shared_ptr<warp::Retargeter>>(engine(
      retargeter_key(image, method, saliency, lines),
      [this, image, &method, saliency, lines] { return Engine(load_retargeter(image, method, saliency, lines)); }, stop));
}

std::shared_ptr<warp::Retargeter> WarpEngines::retargeter_for_screen(const tiles::ImageEntry& image,
                                                                     const warp::RetargetingMethod& method,
                                                                     warp::Saliency saliency, warp::LineSet lines,
                                                                     int screen_width, int screen_height,
                                                                     const warp::StopToken* stop, warp::ZoomFrame frame) {
  const std::string key = retargeter_key(image, method, saliency, lines);
  // The warp is per target size: the screen and the frame's aspect (warp/window/fit.h).
  const double aspect = warp::frame_aspect(frame, screen_width, screen_height);
  const std::string screen = std::to_string(screen_width) + "x" + std::to_string(screen_height) + "@" + std::to_string(aspect);
  // The engines whose warp for a screen has been computed, by address: an engine evicted and
  // loaded again is another object, whose caches are empty.
  const auto warmed = [&](const std::shared_ptr<warp::Retargeter>& engine) {
    return std::to_string(reinterpret_cast<std::uintptr_t>(engine.get())) + "|" + screen;
  };
  if (auto kept = engines_.find(key)) {
    auto engine = std::get<std::shared_ptr<warp::Retargeter>>(*kept);
    std::lock_guard lock(warmed_mu_);
    if (warmed_.count(warmed(engine))) return engine;
  }
  // One flight for the engine (loaded there unless kept) and the whole image retargeted to the
  // screen's aspect ratio, cached inside the engine per target size: a first view that runs out
  // of time leaves both to finish, so that its retry is answered from them.
  tiles::BackgroundFlights<Engine>::Future flight;
  try {
    flight = background_.run(key + "|" + screen, [this, key, image, &method, saliency, lines, screen_width, screen_height, frame] {
      const auto engine = std::get<std::shared_ptr<warp::Retargeter>>(
          engines_.get(key, [&] { return Engine(load_retargeter(image, method, saliency, lines)); }).value);
      warp::ViewRequest whole;  // zoom 0: the whole retargeted image, no deadline
      whole.cx = 0, whole.cy = 0, whole.screen_width = screen_width, whole.screen_height = screen_height;
      whole.frame = frame;
      try {
        engine->view(whole);
      } catch (const warp::NoMesh&) {
        engine->screen_sources(whole);  // seam carving: its carving for the screen
      }
      return Engine(engine);
    });
  } catch (const tiles::BackgroundFlights<Engine>::Busy& busy) {
    throw ApiError(503, "busy", std::string(busy.what()) + "; retry shortly").with_retry_after(kRetryAfterSeconds);
  }
  auto engine = std::get<std::shared_ptr<warp::Retargeter>>(await(flight, stop));
  std::lock_guard lock(warmed_mu_);
  if (warmed_.size() >= kMaxWarmed) warmed_.clear();
  warmed_.insert(warmed(engine));
  return engine;
}

std::shared_ptr<warp::Retargeter> WarpEngines::view_engine(const tiles::ImageEntry& image, const ViewMethod& method,
                                                           warp::Saliency saliency, warp::LineSet lines,
                                                           const warp::StopToken* stop, int screen_width,
                                                           int screen_height, warp::ZoomFrame frame) {
  if (!method.registered)
    return std::make_shared<warp::IcazRetargeter>(
        get(image, method.reads_saliency ? saliency : warp::Saliency::kDefault, lines, stop), method.icaz_zoom);
  if (screen_width > 0 && screen_height > 0)
    return retargeter_for_screen(image, *method.registered, saliency, lines, screen_width, screen_height, stop, frame);
  return retargeter(image, *method.registered, saliency, lines, stop);
}

std::size_t WarpEngines::memory_bytes() { return engines_.weight(); }

WarpEngines::Counts WarpEngines::counts() const { return {computed_.load(), read_.load(), background_.in_flight()}; }

}  // namespace zoomwarp::api
