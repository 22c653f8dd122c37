#include "api/warp_engines.h"

#include "warp/image_analysis.h"

namespace zoomwarp::api {

WarpEngines::WarpEngines(tiles::PyramidReader& reader, std::size_t capacity)
    : reader_(reader), capacity_(std::max<std::size_t>(1, capacity)) {}

std::shared_ptr<warp::Icaz> WarpEngines::load(const tiles::ImageEntry& image) {
  warp::ImageModel model;
  try {
    model = warp::read_image_model(image);
  } catch (const std::runtime_error&) {
    // A version published before the model files existed: build the model from its pyramid.
    model = warp::make_image_model(warp::read_reduced_image(image, reader_), image.manifest.width,
                                   image.manifest.height);
  }
  return std::make_shared<warp::Icaz>(std::move(model));
}

std::shared_ptr<warp::Icaz> WarpEngines::get(const tiles::ImageEntry& image) {
  const std::string key = image.dir;  // one folder per version
  std::promise<std::shared_ptr<warp::Icaz>> promise;
  Future future;
  {
    std::lock_guard lock(mu_);
    if (auto it = engines_.find(key); it != engines_.end()) {
      order_.splice(order_.begin(), order_, it->second.second);
      future = it->second.first;
    } else {
      future = promise.get_future().share();
      order_.push_front(key);
      engines_.emplace(key, std::make_pair(future, order_.begin()));
      while (engines_.size() > capacity_) {
        engines_.erase(order_.back());
        order_.pop_back();
      }
      future = Future();  // this caller loads
    }
  }
  if (future.valid()) return future.get();
  try {
    auto engine = load(image);
    promise.set_value(engine);
    return engine;
  } catch (...) {
    promise.set_exception(std::current_exception());
    std::lock_guard lock(mu_);
    if (auto it = engines_.find(key); it != engines_.end()) {
      order_.erase(it->second.second);
      engines_.erase(it);
    }
    throw;
  }
}

}  // namespace zoomwarp::api
