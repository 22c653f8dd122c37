// A least-recently-used map from string keys to shared immutable values, bounded by the bytes the
// values hold (as the caller counts them). Thread-safe; values stay alive while a reader holds them
// even after eviction. Used for encoded responses, and later for warp results.
#pragma once

#include <cstddef>
#include <cstdint>
#include <list>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

namespace zoomwarp::tiles {

template <class V>
class ByteLruCache {
 public:
  explicit ByteLruCache(std::size_t max_bytes) : max_bytes_(max_bytes) {}

  std::shared_ptr<const V> get(const std::string& key) {
    std::lock_guard lock(mu_);
    auto it = index_.find(key);
    if (it == index_.end()) {
      ++misses_;
      return nullptr;
    }
    ++hits_;
    order_.splice(order_.begin(), order_, it->second);
    return it->second->value;
  }

  // Inserts or replaces; values larger than an eighth of the budget are not kept, so that one
  // huge response cannot flush everything else.
  void put(const std::string& key, std::shared_ptr<const V> value, std::size_t bytes) {
    bytes += key.size() + kEntryOverhead;
    if (bytes > max_bytes_ / 8) return;
    std::lock_guard lock(mu_);
    if (auto it = index_.find(key); it != index_.end()) erase(it->second);
    order_.push_front(Entry{key, std::move(value), bytes});
    index_.emplace(key, order_.begin());
    bytes_ += bytes;
    while (bytes_ > max_bytes_ && !order_.empty()) {
      erase(std::prev(order_.end()));
      ++evictions_;
    }
  }

  struct Stats {
    std::uint64_t hits = 0, misses = 0, evictions = 0;
    std::size_t bytes = 0, max_bytes = 0, entries = 0;
  };
  Stats stats() const {
    std::lock_guard lock(mu_);
    return Stats{hits_, misses_, evictions_, bytes_, max_bytes_, index_.size()};
  }

 private:
  static constexpr std::size_t kEntryOverhead = 96;  // list node, map node, control block
  struct Entry {
    std::string key;
    std::shared_ptr<const V> value;
    std::size_t bytes;
  };
  using Iter = typename std::list<Entry>::iterator;

  void erase(Iter it) {
    bytes_ -= it->bytes;
    index_.erase(it->key);
    order_.erase(it);
  }

  const std::size_t max_bytes_;
  mutable std::mutex mu_;
  std::list<Entry> order_;  // most recently used first
  std::unordered_map<std::string, Iter> index_;
  std::size_t bytes_ = 0;
  std::uint64_t hits_ = 0, misses_ = 0, evictions_ = 0;
};

}  // namespace zoomwarp::tiles
