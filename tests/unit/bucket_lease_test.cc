// tiles/bucket_lease.h on an object held in memory, read and written with a delay as a store's
// would be: threads standing for replicas never hold the lease together; a holder that died is
// waited out; a lease held past the deadline is LeaseBusy naming its holder; damaged text is
// nobody's lease.
#include "tiles/bucket_lease.h"

#include <gtest/gtest.h>

#include <atomic>
#include <mutex>
#include <thread>
#include <vector>

namespace zoomwarp::tiles {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

// One key of a store: each request takes `latency`, and a read sees the last write completed.
struct MemoryObject {
  std::mutex mu;
  std::optional<std::string> text;
  std::chrono::milliseconds latency{2};

  LeaseObject object() {
    return LeaseObject{[this] {
                         std::this_thread::sleep_for(latency);
                         std::lock_guard lock(mu);
                         return text;
                       },
                       [this](const std::string& t) {
                         std::this_thread::sleep_for(latency);
                         std::lock_guard lock(mu);
                         text = t;
                       },
                       [this] {
                         std::this_thread::sleep_for(latency);
                         std::lock_guard lock(mu);
                         text.reset();
                       }};
  }
};

LeaseTiming fast() {
  LeaseTiming t;
  t.ttl = 2000ms;
  t.settle = 20ms;
  t.skew = 200ms;
  t.poll = 5ms;
  return t;
}

TEST(BucketLease, ContendersNeverHoldItTogether) {
  MemoryObject store;
  const LeaseTiming timing = fast();
  std::atomic<int> inside{0}, most{0}, acquired{0};
  std::vector<std::thread> replicas;
  for (int r = 0; r < 4; ++r)
    replicas.emplace_back([&] {
      for (int i = 0; i < 8; ++i) {
        const LeaseObject lease = store.object();
        const HeldLease held = acquire_lease(lease, timing, Clock::now() + 30s);
        const int now = ++inside;
        most = std::max(most.load(), now);
        EXPECT_GT(lease_time_left(held, timing), 0ms);
        std::this_thread::sleep_for(3ms);  // the pointer move
        --inside;
        ++acquired;
        release_lease(lease, held, timing);
      }
    });
  for (auto& t : replicas) t.join();
  EXPECT_EQ(most.load(), 1) << "two held the lease at once";
  EXPECT_EQ(acquired.load(), 32);
  EXPECT_FALSE(store.text.has_value()) << "released";
}

TEST(BucketLease, AHolderThatDiedIsWaitedOutAndABusyOneIsNamed) {
  MemoryObject store;
  LeaseTiming timing = fast();
  const HeldLease dead = acquire_lease(store.object(), timing, Clock::now() + 5s);  // never released
  try {
    acquire_lease(store.object(), timing, Clock::now() + 300ms);
    ADD_FAILURE() << "taken while held";
  } catch (const LeaseBusy& e) {
    EXPECT_EQ(e.holder, dead.token);
  }
  const auto t0 = Clock::now();
  const HeldLease next = acquire_lease(store.object(), timing, Clock::now() + 10s);
  EXPECT_NE(next.token, dead.token);
  EXPECT_GE(Clock::now() - t0, timing.ttl + timing.skew - 400ms) << "not before the dead holder's lease ran out";
}

TEST(BucketLease, TextRoundTripsAndDamagedTextIsNobodys) {
  const HeldLease h{"host.12.ab", 1'700'000'000'123};
  const auto back = parse_lease(lease_text(h));
  ASSERT_TRUE(back);
  EXPECT_EQ(back->token, h.token);
  EXPECT_EQ(back->expires_ms, h.expires_ms);
  for (const char* bad : {"", "x", " 12", "host 12x", "host"}) EXPECT_FALSE(parse_lease(bad)) << bad;
  MemoryObject store;
  store.text = "garbage";
  const auto t0 = Clock::now();
  acquire_lease(store.object(), fast(), Clock::now() + 5s);
  EXPECT_LT(Clock::now() - t0, 1s) << "taken over at once";
}

}  // namespace
}  // namespace zoomwarp::tiles
