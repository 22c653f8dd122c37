#include "api/collection_index.h"

#include <nlohmann/json.hpp>

namespace zoomwarp::api {

CollectionIndex::CollectionIndex(tiles::Store& store, EventLog log) : store_(store), log_(std::move(log)) {}

std::shared_ptr<const std::vector<CollectionIndex::Listed>> CollectionIndex::current() {
  std::lock_guard lock(mu_);
  const auto now = std::chrono::steady_clock::now();
  const std::uint64_t generation = store_.generation();
  if (index_ && generation == generation_ && now - made_at_ < store_.recheck()) return index_;
  auto index = std::make_shared<std::vector<Listed>>();
  for (auto& image : store_.list()) {
    if (image->manifest.is_private) continue;
    Description description;
    try {
      description = read_description(*image);
    } catch (const std::exception& e) {
      if (log_) {
        nlohmann::json fields = nlohmann::json::object();
        fields["image"] = image->manifest.id;
        fields["version"] = image->manifest.version;
        fields["error"] = e.what();
        log_("warn", "a damaged description is left out of the collection", fields);
      }
    }
    index->push_back({std::move(image), std::move(description)});
  }
  index_ = std::move(index);
  generation_ = generation, made_at_ = now;
  return index_;
}

}  // namespace zoomwarp::api
