// tiles::SingleFlight (tiles/single_flight.h): one computation for concurrent callers of a key, its
// error to every one of them and never kept, and the kept values' least-recently-used eviction.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tiles/single_flight.h"

namespace zoomwarp {
namespace {

using Flights = tiles::SingleFlight<int>;

// Holds a computation until `n` other callers wait on its flight, so they all arrive while it is
// in the air. The bound only keeps a broken single flight (nobody waits) from hanging the test.
class Gate {
 public:
  explicit Gate(int n) : n_(n) {}
  void arrive() {
    std::lock_guard lock(mu_);
    ++waiting_;
    cv_.notify_all();
  }
  void hold() {
    std::unique_lock lock(mu_);
    cv_.wait_for(lock, std::chrono::seconds(10), [&] { return waiting_ >= n_; });
  }

 private:
  const int n_;
  int waiting_ = 0;
  std::mutex mu_;
  std::condition_variable cv_;
};

constexpr int kCallers = 8;

// Runs `kCallers` concurrent get("k") calls and waits for them. The one that computes counts in
// `computed` and holds until all the others wait on its flight. `body(i, get)` is caller i:
// get(compute) calls flights.get("k", …) with that computation.
template <class Body>
void run_callers(Flights& flights, Gate& gate, std::atomic<int>& computed, Body body) {
  const auto wait = [&](const Flights::Future& f) {
    gate.arrive();
    f.wait();
  };
  std::vector<std::thread> threads;
  for (int i = 0; i < kCallers; ++i)
    threads.emplace_back([&, i] {
      body(i, [&](auto compute) {
        return flights.get("k", [&] {
          ++computed;
          gate.hold();
          return compute();
        }, wait);
      });
    });
  for (auto& t : threads) t.join();
}

TEST(SingleFlight, ConcurrentCallersComputeOnce) {
  for (const bool keeps : {false, true}) {
    Flights flights = keeps ? Flights(100, [](const int&) { return 1; }) : Flights();
    Gate gate(kCallers - 1);
    std::atomic<int> computed = 0, leaders = 0;
    std::vector<int> got(kCallers, 0);
    run_callers(flights, gate, computed, [&](int i, auto get) {
      const auto r = get([] { return 42; });
      got[std::size_t(i)] = r.value;
      if (r.computed) ++leaders;
    });
    EXPECT_EQ(computed, 1) << "keeps " << keeps;
    EXPECT_EQ(leaders, 1);
    EXPECT_EQ(got, std::vector<int>(kCallers, 42));
    // Landed: computed again when nothing is kept, else the kept value.
    EXPECT_EQ(flights.get("k", [] { return 7; }).value, keeps ? 42 : 7);
  }
}

TEST(SingleFlight, AnErrorReachesEveryWaiterAndIsNotKept) {
  for (const bool keeps : {false, true}) {
    Flights flights = keeps ? Flights(100, [](const int&) { return 1; }) : Flights();
    Gate gate(kCallers - 1);
    std::atomic<int> computed = 0, failed = 0;
    run_callers(flights, gate, computed, [&](int, auto get) {
      try {
        get([]() -> int { throw std::runtime_error("model damaged"); });
      } catch (const std::runtime_error& e) {
        if (std::string(e.what()) == "model damaged") ++failed;
      }
    });
    EXPECT_EQ(computed, 1) << "keeps " << keeps;
    EXPECT_EQ(failed, kCallers);
    const auto next = flights.get("k", [] { return 5; });
    EXPECT_TRUE(next.computed);
    EXPECT_EQ(next.value, 5);
    EXPECT_EQ(flights.weight(), keeps ? 1u : 0u);
  }
}

// A waiter that gives up leaves the flight to land for the others; with values kept, it is kept.
TEST(SingleFlight, AWaiterThatGivesUpLeavesTheFlightGoing) {
  Flights flights(100, [](const int&) { return 1; });
  Gate gate(1);
  std::promise<void> computing;
  std::thread leader([&] {
    flights.get("k", [&] {
      computing.set_value();
      gate.hold();
      return 3;
    });
  });
  computing.get_future().wait();  // its flight is in the air: the next caller waits on it
  EXPECT_THROW(flights.get("k", [] { return 9; }, [&](const Flights::Future&) {
    gate.arrive();
    throw std::runtime_error("out of time");
  }), std::runtime_error);
  leader.join();
  const auto kept = flights.get("k", [] { return 9; });
  EXPECT_FALSE(kept.computed);
  EXPECT_EQ(kept.value, 3);
}

// Keys "a"…: each value weighs its own number; computes() says whether get() computed.
struct Weighed {
  Flights flights{3, [](const int& v) { return std::size_t(v); }};
  bool computes(const std::string& key, int weight = 1) {
    return flights.get(key, [&] { return weight; }).computed;
  }
};

TEST(SingleFlight, DropsTheLeastRecentlyUsedValueOverCapacity) {
  Weighed w;
  EXPECT_TRUE(w.computes("a"));
  EXPECT_TRUE(w.computes("b"));
  EXPECT_TRUE(w.computes("c"));
  EXPECT_FALSE(w.computes("a"));  // a used again: b is now the least recent
  EXPECT_TRUE(w.computes("d"));   // 4 > 3: b dropped
  EXPECT_EQ(w.flights.weight(), 3u);
  EXPECT_FALSE(w.computes("a"));
  EXPECT_FALSE(w.computes("c"));
  EXPECT_FALSE(w.computes("d"));
  EXPECT_TRUE(w.computes("b"));  // b again; a, the least recent now, dropped
  EXPECT_TRUE(w.computes("a"));
}

// Values are weighed on every use (an engine grows as views visit it); the one just used stays
// even when it alone is over capacity.
TEST(SingleFlight, WeighsOnEveryUseAndKeepsTheValueJustUsed) {
  int weight = 1;
  Flights flights(3, [&](const int&) { return std::size_t(weight); });
  flights.get("a", [] { return 0; });
  flights.get("b", [] { return 0; });
  EXPECT_EQ(flights.weight(), 2u);
  weight = 5;  // b grows past the capacity on its next use: a goes, b stays
  EXPECT_FALSE(flights.get("b", [] { return 0; }).computed);
  EXPECT_EQ(flights.weight(), 5u);
  EXPECT_FALSE(flights.get("b", [] { return 0; }).computed);
  weight = 1;
  EXPECT_TRUE(flights.get("a", [] { return 0; }).computed);
}

}  // namespace
}  // namespace zoomwarp
