// A cache of the `capacity` most recently used values by key: what a Retargeter keeps per target
// size (a warp, a carve table) so that a screen aspect seen before costs a lookup.
//
// Thread safety: none, except bytes(); the owner locks (its mutex usually also makes the
// computation of a missing value single-flight, so it is held for a whole solve).
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <list>
#include <utility>

namespace zoomwarp::warp {

template <class Key, class Value>
class RecentCache {
 public:
  using Weigh = std::function<std::size_t(const Value&)>;

  // `weigh` counts a value's bytes for bytes(); values must not change size once stored.
  explicit RecentCache(std::size_t capacity, Weigh weigh = {}) : capacity_(capacity), weigh_(std::move(weigh)) {}

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
    bytes_ += weight(entries_.front().second);
    if (entries_.size() > capacity_) {
      bytes_ -= weight(entries_.back().second);
      entries_.pop_back();
    }
    return entries_.front().second;
  }

  // The stored values' bytes as `weigh` counts them (0 without it). Unlike the rest, this may be
  // called from any thread without the owner's lock: the engines' memory accounting asks on every
  // request and must not wait behind a solve that lock is held for.
  std::size_t bytes() const { return bytes_.load(std::memory_order_relaxed); }

  // Every entry, most recently used first (e.g. to pick a warm start, to count bytes).
  const std::list<std::pair<Key, Value>>& entries() const { return entries_; }

 private:
  std::size_t weight(const Value& v) const { return weigh_ ? weigh_(v) : 0; }

  const std::size_t capacity_;
  const Weigh weigh_;
  std::list<std::pair<Key, Value>> entries_;
  std::atomic<std::size_t> bytes_{0};
};

}  // namespace zoomwarp::warp
