// warp/core/parallel_for.h: every index exactly once, on more than one thread where the machine
// has them, started by the caller (so at its nice value), and a body's exception comes back.
#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <mutex>
#include <set>
#include <stdexcept>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "warp/core/parallel_for.h"

namespace zoomwarp::warp {
namespace {

int own_nice() { return ::getpriority(PRIO_PROCESS, pid_t(::syscall(SYS_gettid))); }

TEST(ParallelFor, CallsEveryIndexExactlyOnce) {
  for (int n : {0, 1, 2, 3, 7, 1000}) {
    std::vector<std::atomic<int>> calls(static_cast<std::size_t>(n));
    parallel_for(n, [&](int i) { ++calls[std::size_t(i)]; });
    for (int i = 0; i < n; ++i) EXPECT_EQ(calls[std::size_t(i)], 1) << "n " << n << " index " << i;
  }
}

TEST(ParallelFor, UsesUpToFourThreadsStartedAtTheCallersPriority) {
  EXPECT_GE(analysis_parallelism(), 1);
  EXPECT_LE(analysis_parallelism(), 4);
  // In a thread of its own, ten nice levels down, as a background analysis runs.
  std::mutex mutex;
  std::set<std::thread::id> threads;
  std::set<int> nices;
  int caller_nice = 0;
  std::thread([&] {
    ::setpriority(PRIO_PROCESS, pid_t(::syscall(SYS_gettid)), std::min(19, own_nice() + 10));
    caller_nice = own_nice();
    parallel_for(64, [&](int) {
      std::this_thread::sleep_for(std::chrono::milliseconds(2));  // so that every thread gets some
      std::lock_guard lock(mutex);
      threads.insert(std::this_thread::get_id());
      nices.insert(own_nice());
    });
  }).join();
  EXPECT_EQ(int(threads.size()), analysis_parallelism());
  EXPECT_EQ(nices, std::set<int>{caller_nice}) << "every thread at the caller's nice value";
}

TEST(ParallelFor, RethrowsABodysExceptionAfterEveryThreadStopped) {
  std::atomic<int> running{0}, calls{0};
  EXPECT_THROW(parallel_for(1000,
                            [&](int i) {
                              ++running, ++calls;
                              if (i == 3) {
                                --running;
                                throw std::runtime_error("cell 3");
                              }
                              std::this_thread::sleep_for(std::chrono::microseconds(200));
                              --running;
                            }),
               std::runtime_error);
  EXPECT_EQ(running, 0) << "no body still running when it returned";
  EXPECT_LT(calls, 1000) << "no index started after the failure was seen";
}

}  // namespace
}  // namespace zoomwarp::warp
