// tiles::run_jobs: jobs side by side on a few threads while their estimated peaks fit a memory
// budget (ingest's analysis, issue 18).
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <future>
#include <mutex>
#include <stdexcept>
#include <vector>

#include "tiles/parallel_jobs.h"

namespace zoomwarp {
namespace {

using namespace std::chrono_literals;

// What the jobs saw of each other: the most bytes and jobs running at once.
struct Watch {
  std::mutex mutex;
  std::size_t bytes = 0, jobs = 0, most_bytes = 0, most_jobs = 0;
  bool held_out = false;  // a held job ran out its second: nothing released it
  void enter(std::size_t b) {
    std::lock_guard lock(mutex);
    bytes += b, ++jobs;
    most_bytes = std::max(most_bytes, bytes), most_jobs = std::max(most_jobs, jobs);
  }
  void leave(std::size_t b) {
    std::lock_guard lock(mutex);
    bytes -= b, --jobs;
  }
};

// A job of `bytes` that stays running until `until` is set (or a second has passed), so that
// whatever may run beside it does.
tiles::Job held_job(Watch& watch, std::size_t bytes, std::shared_future<void> until) {
  return {[&watch, bytes, until] {
            watch.enter(bytes);
            const bool released = until.wait_for(1s) == std::future_status::ready;
            watch.leave(bytes);
            if (!released) {
              std::lock_guard lock(watch.mutex);
              watch.held_out = true;
            }
          },
          bytes};
}

TEST(RunJobs, SmallJobsRunBesideALargeOneButTwoLargeOnesNever) {
  Watch watch;
  std::promise<void> small_ran;
  std::shared_future<void> release = small_ran.get_future().share();
  std::atomic<int> small_jobs = 0;
  std::vector<tiles::Job> jobs = {held_job(watch, 40, release), held_job(watch, 40, release)};
  // The small jobs come last in order: a free thread skips the second large one to take them.
  for (int i = 0; i < 2; ++i)
    jobs.push_back({[&] {
                      watch.enter(10);
                      if (++small_jobs == 2) small_ran.set_value();
                      watch.leave(10);
                    },
                    10});
  tiles::run_jobs(jobs, 2, 50);
  EXPECT_EQ(small_jobs, 2);
  EXPECT_FALSE(watch.held_out) << "the small jobs ran while the first large one was running";
  EXPECT_EQ(watch.most_jobs, 2u);
  EXPECT_LE(watch.most_bytes, 50u) << "the two large jobs never ran together";
}

TEST(RunJobs, AJobOverTheBudgetRunsAlone) {
  Watch watch;
  std::promise<void> never;
  std::shared_future<void> held = never.get_future().share();  // each job holds for its second
  tiles::run_jobs(std::vector<tiles::Job>{held_job(watch, 100, held), held_job(watch, 5, held)}, 2, 50);
  EXPECT_EQ(watch.most_jobs, 1u);
}

TEST(RunJobs, WithinTheBudgetJobsRunOnEveryThread) {
  Watch watch;
  std::promise<void> never;
  std::shared_future<void> held = never.get_future().share();
  tiles::run_jobs(std::vector<tiles::Job>{held_job(watch, 20, held), held_job(watch, 20, held), held_job(watch, 20, held)},
                  3, 60);
  EXPECT_EQ(watch.most_jobs, 3u);
}

TEST(RunJobs, EveryJobRunsAndTheFirstFailureInOrderIsRethrown) {
  std::atomic<int> ran = 0;
  const std::vector<tiles::Job> jobs = {
      {[&] { ++ran; }, 1},
      {[&] { ++ran, throw std::runtime_error("second"); }, 1},
      {[&] { ++ran, throw std::logic_error("third"); }, 1},
      {[&] { ++ran; }, 1},
  };
  for (int threads : {1, 2}) {
    ran = 0;
    try {
      tiles::run_jobs(jobs, threads, 1);
      ADD_FAILURE() << "no exception";
    } catch (const std::runtime_error& e) {
      EXPECT_STREQ(e.what(), "second");
    }
    EXPECT_EQ(ran, 4) << threads << " threads";
  }
}

}  // namespace
}  // namespace zoomwarp
