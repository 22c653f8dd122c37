// Views of one image from several threads at once give exactly what the same views give one
// after another (the model is shared read-only; only the caches are locked), and a view stops
// when its request's token says so — already expired, or cancelled from another thread mid-way.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <future>
#include <limits>
#include <random>
#include <thread>
#include <vector>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/icaz/icaz.h"
#include "warp/methods/retarget_zoom/retarget_zoom.h"

namespace zoomwarp {
namespace {

warp::ImageModel boats_model(const std::vector<warp::Segment>& lines = {}) {
  const tiles::Raster full = testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg");
  const tiles::Raster small = testing::resize(full, full.width / 4, full.height / 4);
  return warp::make_image_model(small, full.width, full.height, lines);
}

// Requests that differ in zoom and centre; one screen, so the coarse warps they share are solved
// to the same tolerance whichever request comes first.
std::vector<warp::ViewRequest> requests() {
  std::vector<warp::ViewRequest> out;
  for (double zoom : {0.0, 0.3, 0.6, 0.9, 1.0})
    for (double cx : {300.0, 1200.0, 2200.0}) {
      warp::ViewRequest r;
      r.zoom = zoom, r.cx = cx, r.cy = 700;
      out.push_back(r);
    }
  return out;
}

// Every index below n once, in an order of its own per thread (seeded).
std::vector<std::size_t> order_for(int thread, std::size_t n) {
  std::vector<std::size_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = i;
  std::mt19937 rng(1234 + thread);
  std::shuffle(order.begin(), order.end(), rng);
  return order;
}

void expect_same(const warp::View& a, const warp::View& b) {
  ASSERT_EQ(a.screen.size(), b.screen.size());
  ASSERT_EQ(a.forest_vertex, b.forest_vertex);
  for (std::size_t i = 0; i < a.screen.size(); ++i) {
    ASSERT_EQ(a.screen[i].x, b.screen[i].x);
    ASSERT_EQ(a.screen[i].y, b.screen[i].y);
  }
}

TEST(IcazConcurrency, ParallelViewsEqualSequentialOnes) {
  const warp::ImageModel model = boats_model();
  const auto reqs = requests();
  std::vector<warp::View> sequential;
  {
    warp::Icaz icaz(model);
    for (const auto& r : reqs) sequential.push_back(icaz.view(r));
  }
  // A fresh engine (empty caches), four threads each running every request in its own order.
  warp::Icaz icaz(model);
  constexpr int kThreads = 4;
  std::vector<std::vector<warp::View>> results(kThreads, std::vector<warp::View>(reqs.size()));
  std::atomic<int> failures{0};
  std::vector<std::thread> threads;
  for (int t = 0; t < kThreads; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t i : order_for(t, reqs.size())) {
        try {
          results[t][i] = icaz.view(reqs[i]);
        } catch (...) {
          ++failures;
        }
      }
    });
  for (auto& th : threads) th.join();
  ASSERT_EQ(failures, 0);
  for (int t = 0; t < kThreads; ++t)
    for (std::size_t i = 0; i < reqs.size(); ++i) {
      SCOPED_TRACE(::testing::Message() << "thread " << t << " request " << i);
      expect_same(results[t][i], sequential[i]);
    }
}

// Lazy forest nodes (a forest stored only to its roots) are made by whichever view needs them
// first, while other views read the forest. Which view makes a node first changes vertex ids
// (and so ties in the longest-edge order), so the check is against the same engine once the
// forest has grown: every view made in the race equals the same view made again alone, has no
// fold-over, and geomorphs work across views of different threads.
TEST(IcazConcurrency, LazyForestGrowsUnderParallelViews) {
  warp::ImageModel model = boats_model();
  model.forest = warp::Forest(model.coarse.mesh);  // nothing stored below the roots
  model.node_mean.resize(std::size_t(model.forest.kept_nodes()));
  const auto reqs = requests();
  warp::Icaz icaz(model);
  std::vector<std::vector<warp::View>> results(3, std::vector<warp::View>(reqs.size()));
  std::vector<std::thread> threads;
  for (int t = 0; t < 3; ++t)
    threads.emplace_back([&, t] {
      for (std::size_t i : order_for(t, reqs.size())) results[t][i] = icaz.view(reqs[i]);
    });
  for (auto& th : threads) th.join();
  for (std::size_t i = 0; i < reqs.size(); ++i) {
    const warp::View alone = icaz.view(reqs[i]);
    for (const auto& t : alone.source.triangles)
      ASSERT_GT(warp::signed_area2(alone.screen[t[0]], alone.screen[t[1]], alone.screen[t[2]]), 0) << "fold-over";
    for (int t = 0; t < 3; ++t) {
      SCOPED_TRACE(::testing::Message() << "thread " << t << " request " << i);
      expect_same(results[t][i], alone);
    }
  }
  EXPECT_NO_THROW(icaz.geomorph(results[0][1], results[1][2]));
}

// The engines' memory budget asks memory_bytes() on every request (api/warp_engines.h), so it
// must answer while a view holds the coarse-cache lock for a solve. The hook holds the solve
// until memory_bytes() has answered on another thread: a memory_bytes() that waited for the lock
// would wait for the hook, which gives up only after a generous safety timeout — the test fails.
TEST(IcazMemory, MemoryBytesAnswersWhileACoarseSolveHoldsTheLock) {
  std::promise<void> solving, answered;
  std::shared_future<void> answered_future = answered.get_future().share();
  std::atomic<bool> held = false, answered_during_solve = false;
  warp::IcazOptions options;
  options.before_coarse_solve = [&] {
    if (held.exchange(true)) return;  // hold the first solve only
    solving.set_value();
    answered_during_solve = answered_future.wait_for(std::chrono::seconds(60)) == std::future_status::ready;
  };
  warp::Icaz icaz(boats_model(), options);
  const std::size_t before = icaz.memory_bytes();
  warp::ViewRequest r;
  r.zoom = 0.5, r.cx = 1000, r.cy = 700;
  std::thread viewer([&] { icaz.view(r); });
  solving.get_future().wait();
  std::size_t during = 0;
  std::thread asker([&] {
    during = icaz.memory_bytes();
    answered.set_value();
  });
  asker.join();
  viewer.join();
  EXPECT_TRUE(answered_during_solve) << "memory_bytes() waited for the coarse solve";
  EXPECT_EQ(during, before) << "nothing was cached yet";
  EXPECT_GT(icaz.memory_bytes(), before) << "the coarse warp and its anchors count once cached";
}

TEST(IcazStop, AnExpiredTokenStopsTheView) {
  warp::Icaz icaz(boats_model());
  const warp::StopToken expired(warp::StopToken::Clock::now() - std::chrono::seconds(1));
  warp::ViewRequest r;
  r.zoom = 0.5, r.cx = 1000, r.cy = 700, r.stop = &expired;
  try {
    icaz.view(r);
    FAIL() << "the view ran past its deadline";
  } catch (const warp::Stopped& e) {
    EXPECT_EQ(e.reason(), warp::Stopped::Reason::kDeadline);
  }
  EXPECT_THROW(warp::RetargetZoom(icaz.model(), icaz.model().significance).view(r), warp::Stopped);
  r.stop = nullptr;
  EXPECT_NO_THROW(icaz.view(r)) << "a stopped view leaves the engine usable";
}

// A view made long on purpose (a huge refined mesh with an oblique line, i.e. the joint path) is
// cancelled from another thread once it has started: it throws Stopped(kCancelled).
TEST(IcazStop, ACancelFromAnotherThreadStopsARunningView) {
  const double W = 2560, H = 1600;  // boats_lake_sunset.jpg
  warp::IcazOptions options;
  options.max_screen_triangles = 1 << 30;
  options.solve_margin = std::numeric_limits<double>::infinity();
  warp::Icaz icaz(boats_model({{{0.1 * W, 0.2 * H}, {0.9 * W, 0.7 * H}}}), options);
  warp::StopToken token;
  warp::ViewRequest r;
  r.zoom = 0.5, r.cx = W / 2, r.cy = H / 2, r.screen_width = 4096, r.screen_height = 4096, r.max_screen_area = 1;
  r.stop = &token;
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    token.cancel();
  });
  try {
    icaz.view(r);
    ADD_FAILURE() << "the view was not cancelled";
  } catch (const warp::Stopped& e) {
    EXPECT_EQ(e.reason(), warp::Stopped::Reason::kCancelled);
  }
  canceller.join();
}

}  // namespace
}  // namespace zoomwarp
