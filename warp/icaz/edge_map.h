// A hash map from 64-bit keys to small values, with open addressing and linear probing in one
// flat array: `EdgeMap`, from an undirected edge (forest.h's edge_key) to the up to two LOD-cut
// nodes on it, and LodCut::mesh's forest vertex → mesh vertex numbering. LodCut does a few
// lookups per split and every view starts from a copy of the coarsest cut: a flat array copies
// with one memcpy and probes without chasing the per-element allocations of std::unordered_map
// (which made the cut ~a fifth of a pan's time, and numbering the cut's vertices with it a tenth).
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <vector>

namespace zoomwarp::warp {

template <class Value>
class FlatMap {
 public:
  // The value of `key`, or null.
  Value* find(std::uint64_t key) {
    if (keys_.empty()) return nullptr;
    for (std::size_t i = slot(key);; i = (i + 1) & mask_) {
      if (keys_[i] == kEmpty) return nullptr;
      if (keys_[i] == key) return &values_[i];
    }
  }
  const Value* find(std::uint64_t key) const { return const_cast<FlatMap*>(this)->find(key); }

  // The entry for `key`, made with `value` if missing; second: whether it was made.
  std::pair<Value*, bool> emplace(std::uint64_t key, const Value& value) {
    if (2 * (size_ + 1) > keys_.size()) grow();
    std::size_t i = slot(key);
    for (; keys_[i] != kEmpty; i = (i + 1) & mask_)
      if (keys_[i] == key) return {&values_[i], false};
    keys_[i] = key, values_[i] = value, ++size_;
    return {&values_[i], true};
  }

  // Removes `key` (which must be present). Backward-shift deletion keeps every probe sequence
  // unbroken without tombstones.
  void erase(std::uint64_t key) {
    std::size_t hole = slot(key);
    while (keys_[hole] != key) hole = (hole + 1) & mask_;
    for (std::size_t i = (hole + 1) & mask_; keys_[i] != kEmpty; i = (i + 1) & mask_) {
      const std::size_t home = slot(keys_[i]);
      // Move i into the hole unless its home lies cyclically in (hole, i].
      if (((i - home) & mask_) >= ((i - hole) & mask_)) {
        keys_[hole] = keys_[i], values_[hole] = values_[i];
        hole = i;
      }
    }
    keys_[hole] = kEmpty;
    --size_;
  }

  std::size_t size() const { return size_; }

  // Room for n entries without growing.
  void reserve(std::size_t n) {
    std::size_t capacity = std::max<std::size_t>(64, keys_.size());
    while (capacity < 2 * n) capacity *= 2;
    if (capacity > keys_.size()) rehash(capacity);
  }

 private:
  static constexpr std::uint64_t kEmpty = ~std::uint64_t(0);  // no edge or vertex id has this key

  std::size_t slot(std::uint64_t key) const {
    return std::size_t((key * 0x9E3779B97F4A7C15ull) >> 20) & mask_;  // Fibonacci hashing
  }

  void grow() { rehash(std::max<std::size_t>(64, 2 * keys_.size())); }

  void rehash(std::size_t capacity) {  // a power of two
    std::vector<std::uint64_t> keys(capacity, kEmpty);
    std::vector<Value> values(keys.size());
    keys.swap(keys_), values.swap(values_);
    mask_ = keys_.size() - 1, size_ = 0;
    for (std::size_t i = 0; i < keys.size(); ++i)
      if (keys[i] != kEmpty) emplace(keys[i], values[i]);
  }

  std::vector<std::uint64_t> keys_;
  std::vector<Value> values_;
  std::size_t mask_ = 0, size_ = 0;
};

using EdgeMap = FlatMap<std::array<int, 2>>;  // edge → the up to two nodes on it

}  // namespace zoomwarp::warp
