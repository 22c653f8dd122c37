#include "api/warp_engines.h"

#include <algorithm>
#include <nlohmann/json.hpp>

#include "api/errors.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"

namespace zoomwarp::api {

WarpEngines::WarpEngines(tiles::PyramidReader& reader, std::size_t budget_bytes, warp::SignificanceOptions significance,
                         EventLog log)
    : reader_(reader),
      budget_(budget_bytes),
      significance_(std::move(significance)),
      log_(std::move(log)),
      engines_(budget_bytes, [](const Engine& e) { return std::visit([](const auto& p) { return p->memory_bytes(); }, e); }) {}

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
  return std::get<std::shared_ptr<warp::Icaz>>(
      engines_.get(key, [&] { return Engine(load_icaz(image, saliency, auto_lines)); }).value);
}

std::shared_ptr<warp::Retargeter> WarpEngines::retargeter(const tiles::ImageEntry& image,
                                                          const warp::RetargetingMethod& method,
                                                          warp::Saliency saliency) {
  const std::string key = image.dir + "|" + std::string(method.name) + "|" + std::string(warp::saliency_name(saliency));
  return std::get<std::shared_ptr<warp::Retargeter>>(
      engines_.get(key, [&] { return Engine(load_retargeter(image, method, saliency)); }).value);
}

std::size_t WarpEngines::memory_bytes() { return engines_.weight(); }

}  // namespace zoomwarp::api
