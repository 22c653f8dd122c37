// Single flight: the first caller for a key computes its value, and callers asking for the same
// key meanwhile wait for that computation instead of repeating it — a burst of clients opening one
// view costs one warp and one encode (api's Router), an engine is loaded once (api's WarpEngines),
// a rendered tile of a retargeted image is drawn once (warp/render/rendered_tiles.h).
//
// Optionally the computed values are kept under their keys, least recently used dropped first
// while their total weight is over a capacity (WarpEngines' engines, weighed in bytes). Without
// that, a key is computed again once its flight has landed (the Router keeps encoded responses in
// its own byte-bounded cache, tiles/byte_lru_cache.h).
//
// Errors: what `compute` throws reaches the caller that computed and every caller waiting on that
// flight. Nothing failed is kept: the next call for the key computes again. A waiter may give up
// (its `wait` throws); the flight goes on without it.
//
// Thread safety: every member may be called from any thread concurrently; weight() takes no lock
// (an owner's memory accounting may ask it while a flight is in the air). `compute`, `wait` and
// the weigher run without the internal lock held: they may take locks of their own and use this
// object for other keys (a compute that asks for its own key waits for itself forever).
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <exception>
#include <functional>
#include <future>
#include <iterator>
#include <list>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>

namespace zoomwarp::tiles {

template <class V>
class SingleFlight {
 public:
  using Future = std::shared_future<V>;
  using Weigher = std::function<std::size_t(const V&)>;

  struct Result {
    V value;
    bool computed;  // by this call; false: another caller's flight, or a kept value
  };

  // Keeps no value: once a flight has landed, the next call for its key computes again.
  SingleFlight() = default;

  // Keeps the values computed. Every call weighs its value again (values may grow as they are
  // used); then, while the kept values weigh more than `capacity` in all, the least recently used
  // one is dropped — never the one just used, so one value heavier than the capacity stays alone.
  SingleFlight(std::size_t capacity, Weigher weigh) : keeps_(true), capacity_(capacity), weigh_(std::move(weigh)) {}

  // The value under `key`: kept, or being computed by another caller — then `wait(future)`
  // returns once it is ready, or throws to give up — or computed here by `compute()`.
  // Rethrows what the flight's `compute` threw.
  template <class Compute, class Wait>
  Result get(const std::string& key, Compute&& compute, Wait&& wait);

  template <class Compute>
  Result get(const std::string& key, Compute&& compute) {
    return get(key, std::forward<Compute>(compute), [](const Future& f) { f.wait(); });
  }

  // The value kept under `key` (marked most recently used and weighed again), or nothing — also
  // while its flight is in the air: for a caller that computes elsewhere (BackgroundFlights) and
  // asks here first.
  std::optional<V> find(const std::string& key);

  // The kept values' total weight, as last weighed. Lock-free.
  std::size_t weight() const { return total_.load(std::memory_order_relaxed); }

 private:
  struct Entry {
    Future value;
    std::uint64_t flight = 0;  // which flight: a finished one must not touch a later one's entry
    bool kept = false;         // landed and in order_
    std::size_t weight = 0;
    std::list<std::string>::iterator position;
  };
  using Iter = typename std::unordered_map<std::string, Entry>::iterator;

  // The entry of `flight`, or end() when it is gone (dropped, or evicted since).
  Iter find(const std::string& key, std::uint64_t flight) {
    auto it = entries_.find(key);
    return it != entries_.end() && it->second.flight == flight ? it : entries_.end();
  }

  void erase(Iter it) {
    if (it->second.kept) total_ -= it->second.weight, order_.erase(it->second.position);
    entries_.erase(it);
  }

  // A computed value: kept, or off the table — before its waiters wake, so that none of them
  // finds the landed flight again.
  void land(const std::string& key, std::uint64_t flight) {
    std::lock_guard lock(mu_);
    const auto it = find(key, flight);
    if (it == entries_.end()) return;
    if (!keeps_) return erase(it);
    order_.push_front(key);
    it->second.kept = true, it->second.position = order_.begin();
  }

  void drop(const std::string& key, std::uint64_t flight) {
    std::lock_guard lock(mu_);
    if (const auto it = find(key, flight); it != entries_.end()) erase(it);
  }

  void reweigh(const std::string& key, std::uint64_t flight, const V& value) {
    if (!keeps_) return;
    const std::size_t weight = weigh_(value);
    std::lock_guard lock(mu_);
    if (const auto it = find(key, flight); it != entries_.end() && it->second.kept)
      total_ += weight - it->second.weight, it->second.weight = weight;
    while (total_ > capacity_ && order_.size() > 1) {
      const std::string victim = order_.back() == key ? *std::next(order_.rbegin()) : order_.back();
      erase(entries_.find(victim));
    }
  }

  const bool keeps_ = false;
  const std::size_t capacity_ = 0;
  const Weigher weigh_;
  mutable std::mutex mu_;
  std::unordered_map<std::string, Entry> entries_;  // flights in the air, and kept values
  std::list<std::string> order_;                    // kept values' keys, most recently used first
  std::atomic<std::size_t> total_{0};               // kept values' weight (written under mu_)
  std::uint64_t flights_ = 0;
};

template <class V>
template <class Compute, class Wait>
auto SingleFlight<V>::get(const std::string& key, Compute&& compute, Wait&& wait) -> Result {
  std::promise<V> promise;
  Future pending;
  std::uint64_t flight;
  {
    std::lock_guard lock(mu_);
    auto [it, first] = entries_.try_emplace(key);
    Entry& e = it->second;
    if (first) e.value = promise.get_future().share(), e.flight = ++flights_;
    else pending = e.value;
    if (e.kept) order_.splice(order_.begin(), order_, e.position);
    flight = e.flight;
  }
  if (pending.valid()) {
    wait(pending);
    V value = pending.get();  // rethrows the computing caller's error
    reweigh(key, flight, value);
    return {std::move(value), false};
  }
  V value = [&] {
    try {
      return compute();
    } catch (...) {
      drop(key, flight);
      promise.set_exception(std::current_exception());
      throw;
    }
  }();
  land(key, flight);
  promise.set_value(value);
  reweigh(key, flight, value);
  return {std::move(value), true};
}

template <class V>
std::optional<V> SingleFlight<V>::find(const std::string& key) {
  std::optional<V> value;
  std::uint64_t flight;
  {
    std::lock_guard lock(mu_);
    const auto it = entries_.find(key);
    if (it == entries_.end() || !it->second.kept) return std::nullopt;
    order_.splice(order_.begin(), order_, it->second.position);
    value = it->second.value.get();
    flight = it->second.flight;
  }
  reweigh(key, flight, *value);
  return value;
}

}  // namespace zoomwarp::tiles
