// The ingest pool's priority (server/worker_pool.h): its threads, and the threads they start — an
// ingest's compression and analysis helpers (--ingest-threads) — run ten nice levels below the
// request workers, so an upload that takes every core yields them to requests under load.
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <future>
#include <thread>

#include "server/worker_pool.h"

namespace zoomwarp {
namespace {

int own_nice() { return ::getpriority(PRIO_PROCESS, id_t(::gettid())); }

struct Nice {
  int job = 0, started = 0;  // of a job's thread, and of a thread the job starts
};

Nice nice_in(server::WorkerPool& pool) {
  std::promise<Nice> seen;
  EXPECT_TRUE(pool.try_submit([&] {
    Nice n{own_nice(), 0};
    std::thread helper([&] { n.started = own_nice(); });
    helper.join();
    seen.set_value(n);
  }));
  return seen.get_future().get();
}

TEST(WorkerPool, NiceThreadsAndTheThreadsTheyStartRunBelowTheRest) {
  const int base = own_nice();
  server::WorkerPool requests(1, 4);
  server::WorkerPool ingest(1, 4, 10);
  const Nice r = nice_in(requests), i = nice_in(ingest);
  EXPECT_EQ(r.job, base);
  EXPECT_EQ(r.started, base);
  EXPECT_EQ(i.job, std::min(19, base + 10));
  EXPECT_EQ(i.started, i.job);
}

}  // namespace
}  // namespace zoomwarp
