// tiles::BackgroundFlights (tiles/background_flights.h): one run per key while it is in the air,
// to completion whatever its waiters do, failures not kept, a bounded number of keys in flight,
// and its threads below the caller's priority.
#include <gtest/gtest.h>

#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <future>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "tiles/background_flights.h"

namespace zoomwarp {
namespace {

using Flights = tiles::BackgroundFlights<int>;
using namespace std::chrono_literals;

// A latch the test opens: work that waits on it stays in the air until then (bounded, so that a
// broken flight fails instead of hanging).
struct Latch {
  std::promise<void> open;
  std::shared_future<void> opened = open.get_future().share();
  void wait() const { ASSERT_EQ(opened.wait_for(30s), std::future_status::ready); }
};

TEST(BackgroundFlights, ConcurrentRunsOfAKeyShareOneComputation) {
  Flights flights(2, 8);
  Latch latch;
  std::atomic<int> runs{0};
  std::vector<Flights::Future> futures;
  for (int i = 0; i < 5; ++i)
    futures.push_back(flights.run("k", [&] {
      ++runs;
      latch.wait();
      return 42;
    }));
  latch.open.set_value();
  for (auto& f : futures) EXPECT_EQ(f.get(), 42);
  EXPECT_EQ(runs, 1);
}

TEST(BackgroundFlights, TheWorkRunsToItsEndWhenItsWaiterLeaves) {
  Flights flights(1, 8);
  Latch latch;
  std::atomic<bool> finished{false};
  {
    Flights::Future f = flights.run("k", [&] {
      latch.wait();
      finished = true;
      return 1;
    });
    EXPECT_EQ(f.wait_for(10ms), std::future_status::timeout);  // the waiter gives up and goes
  }
  latch.open.set_value();
  for (int i = 0; i < 3000 && !finished; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_TRUE(finished);
}

TEST(BackgroundFlights, AFailureReachesItsWaitersAndIsNotKept) {
  Flights flights(1, 8);
  std::atomic<int> runs{0};
  auto failing = [&]() -> int {
    ++runs;
    throw std::runtime_error("no");
  };
  EXPECT_THROW(flights.run("k", failing).get(), std::runtime_error);
  for (int i = 0; i < 3000 && flights.in_flight() > 0; ++i) std::this_thread::sleep_for(1ms);
  EXPECT_EQ(flights.run("k", [] { return 7; }).get(), 7) << "the next run computes again";
  EXPECT_EQ(runs, 1);
}

TEST(BackgroundFlights, ANewKeyBeyondTheBoundIsRefusedNotQueued) {
  Flights flights(1, 2);
  Latch latch;
  auto held = [&] {
    latch.wait();
    return 0;
  };
  auto a = flights.run("a", held), b = flights.run("b", held);
  EXPECT_THROW(flights.run("c", held), Flights::Busy);
  EXPECT_NO_THROW(flights.run("a", held)) << "a key in flight is joined, not refused";
  latch.open.set_value();
  a.get(), b.get();
}

TEST(BackgroundFlights, ItsThreadsRunBelowTheCallersPriority) {
  Flights flights(1, 2, 10);
  const int mine = ::getpriority(PRIO_PROCESS, id_t(::gettid()));
  const int theirs = flights.run("nice", [] { return ::getpriority(PRIO_PROCESS, id_t(::gettid())); }).get();
  EXPECT_EQ(theirs, std::min(mine + 10, 19));
}

}  // namespace
}  // namespace zoomwarp
