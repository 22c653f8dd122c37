#include "api/warp_engines.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"

namespace zoomwarp::api {

WarpEngines::WarpEngines(tiles::PyramidReader& reader, std::size_t budget_bytes, warp::SignificanceOptions significance,
                         EventLog log)
    : reader_(reader), budget_(budget_bytes), significance_(std::move(significance)), log_(std::move(log)) {}

std::shared_ptr<warp::Icaz> WarpEngines::load_icaz(const tiles::ImageEntry& image, warp::Saliency saliency,
                                                   bool auto_lines) {
  const std::string& id = image.manifest.id;
  warp::LoadedModel loaded;
  try {
    loaded = warp::load_image_model(image, reader_, significance_, {saliency, auto_lines});
  } catch (const warp::ModelFileError& e) {
    if (log_)
      log_("error", "warp model damaged, curator edits unreadable",
           {{"image", id}, {"version", image.manifest.version}, {"file", e.file()}, {"error", e.what()}});
    throw ApiError(500, "model_damaged",
                   "the warp model of image '" + id +
                       "' is damaged and its curator edits (lines, significance) cannot be read; its tiles still "
                       "work; an operator must restore the model files or re-ingest the image");
  }
  if (loaded.source == warp::ModelSource::kRebuiltWithEdits && log_)
    log_("warn", "warp model file damaged, rebuilt with the curator's lines and edits",
         {{"image", id}, {"version", image.manifest.version}, {"file", loaded.damaged_file}, {"error", loaded.reason}});
  if (loaded.unmeshable_suggestions > 0 && log_)
    log_("info", "lines=auto: suggested lines left out, the coarsest mesh cannot be built with them",
         {{"image", id}, {"version", image.manifest.version}, {"left_out", loaded.unmeshable_suggestions}});
  warp::ImageModel& model = loaded.model;
  warp::IcazOptions options;
  constexpr std::size_t kBytesPerLazyNode = 64;
  options.max_forest_nodes = int(std::clamp<std::size_t>(model.forest.kept_nodes() + budget_ / 4 / kBytesPerLazyNode,
                                                         model.forest.kept_nodes() + 10000, 1u << 22));
  return std::make_shared<warp::Icaz>(std::move(model), options);
}

void WarpEngines::evict_over_budget(const std::string& keep) {
  std::size_t total = 0;
  for (const auto& [key, entry] : engines_) total += entry.bytes;
  while (total > budget_ && order_.size() > 1) {
    const std::string victim = order_.back() == keep ? *std::next(order_.rbegin()) : order_.back();
    auto it = engines_.find(victim);
    total -= it->second.bytes;
    order_.erase(it->second.position);
    engines_.erase(it);
  }
}

std::shared_ptr<warp::Retargeter> WarpEngines::load_retargeter(const tiles::ImageEntry& image,
                                                               const warp::RetargetingMethod& method,
                                                               warp::Saliency saliency) {
  // Every method reads the version's model (size, lines, significance): the default ICAZ
  // engine's, loaded once and shared.
  const auto icaz = get(image);
  warp::LoadedRetargeter loaded = warp::load_retargeter(image, reader_, icaz->model(), method, saliency);
  if (loaded.source == warp::MethodSource::kRebuiltDamaged && log_)
    log_("warn", "method model file damaged, precomputed again in memory",
         {{"image", image.manifest.id}, {"version", image.manifest.version}, {"method", method.name},
          {"saliency", warp::saliency_name(saliency)}, {"error", loaded.reason}});
  return std::move(loaded.engine);
}

std::shared_ptr<warp::Icaz> WarpEngines::get(const tiles::ImageEntry& image, warp::Saliency saliency, bool auto_lines) {
  const std::string key = image.dir + "|icaz|" + std::string(warp::saliency_name(saliency)) + (auto_lines ? "|auto" : "");
  return std::get<std::shared_ptr<warp::Icaz>>(cached(key, [&] { return Engine(load_icaz(image, saliency, auto_lines)); }));
}

std::shared_ptr<warp::Retargeter> WarpEngines::retargeter(const tiles::ImageEntry& image,
                                                          const warp::RetargetingMethod& method,
                                                          warp::Saliency saliency) {
  const std::string key = image.dir + "|" + std::string(method.name) + "|" + std::string(warp::saliency_name(saliency));
  return std::get<std::shared_ptr<warp::Retargeter>>(
      cached(key, [&] { return Engine(load_retargeter(image, method, saliency)); }));
}

WarpEngines::Engine WarpEngines::cached(const std::string& key, const std::function<Engine()>& load) {
  std::promise<Engine> promise;
  Future existing;
  {
    std::lock_guard lock(mu_);
    if (auto it = engines_.find(key); it != engines_.end()) {
      order_.splice(order_.begin(), order_, it->second.position);
      existing = it->second.engine;
    } else {
      order_.push_front(key);
      engines_.emplace(key, Entry{promise.get_future().share(), order_.begin(), 0});
    }
  }
  Engine engine;
  if (existing.valid()) {
    engine = existing.get();  // rethrows the loader's error
  } else {
    try {
      engine = load();
      promise.set_value(engine);
    } catch (...) {
      promise.set_exception(std::current_exception());
      std::lock_guard lock(mu_);
      if (auto it = engines_.find(key); it != engines_.end()) {
        order_.erase(it->second.position);
        engines_.erase(it);
      }
      throw;
    }
  }
  // The engine grows as views visit it (lazy forest nodes, caches per target size): measure it again.
  const std::size_t bytes = std::visit([](const auto& e) { return e->memory_bytes(); }, engine);
  std::lock_guard lock(mu_);
  if (auto it = engines_.find(key); it != engines_.end()) it->second.bytes = bytes;
  evict_over_budget(key);
  return engine;
}

std::size_t WarpEngines::memory_bytes() {
  std::lock_guard lock(mu_);
  std::size_t total = 0;
  for (const auto& [key, entry] : engines_) total += entry.bytes;
  return total;
}

}  // namespace zoomwarp::api
