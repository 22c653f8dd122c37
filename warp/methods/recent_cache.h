// A cache of the `capacity` most recently used values by key: what a Retargeter keeps per target
// size (a warp, a carve table) so that a screen aspect seen before costs a lookup.
//
// Thread safety: none; the owner locks (its mutex usually also makes the computation of a
// missing value single-flight).
#pragma once

#include <cstddef>
#include <list>
#include <utility>

namespace zoomwarp::warp {

template <class Key, class Value>
class RecentCache {
 public:
  explicit RecentCache(std::size_t capacity) : capacity_(capacity) {}

  // The value of `key`, now the most recently used, or nullptr. The pointer stays valid until
  // the next put().
  const Value* find(const Key& key) {
    for (auto it = entries_.begin(); it != entries_.end(); ++it)
      if (it->first == key) {
        entries_.splice(entries_.begin(), entries_, it);
        return &entries_.front().second;
      }
    return nullptr;
  }

  // Stores `value` as the most recently used, dropping the least recently used beyond capacity.
  const Value& put(Key key, Value value) {
    entries_.emplace_front(std::move(key), std::move(value));
    if (entries_.size() > capacity_) entries_.pop_back();
    return entries_.front().second;
  }

  // Every entry, most recently used first (e.g. to pick a warm start, to count bytes).
  const std::list<std::pair<Key, Value>>& entries() const { return entries_; }

 private:
  const std::size_t capacity_;
  std::list<std::pair<Key, Value>> entries_;
};

}  // namespace zoomwarp::warp
