// api/failure_cache.h: a remembered failure is answered until its window passes, with Retry-After
// the whole seconds left; the memory is bounded by evicting the least recently used; 0 disables it.
#include "api/failure_cache.h"

#include <gtest/gtest.h>

#include "api/errors.h"

namespace zoomwarp::api {
namespace {

using namespace std::chrono_literals;
using Clock = FailureCache::Clock;

std::string retry_after(const Response& r) {
  for (const auto& [name, value] : r.headers)
    if (name == "Retry-After") return value;
  return "";
}

TEST(FailureCache, AnswersTheFailureUntilItsWindowPasses) {
  FailureCache cache(5000ms, 1 << 20);
  const Clock::time_point t0 = Clock::now();
  cache.put("v1|/a|q", stopped_response(warp::Stopped::Reason::kDeadline), t0);
  for (auto [after, seconds] : {std::pair{0ms, "5"}, {1ms, "5"}, {4000ms, "1"}, {4500ms, "1"}, {4999ms, "1"}}) {
    const auto r = cache.get("v1|/a|q", t0 + after);
    ASSERT_TRUE(r) << after.count();
    EXPECT_EQ(r->status, 503);
    EXPECT_EQ(retry_after(*r), seconds) << after.count() << " ms after";
    EXPECT_EQ(r->failure, "negative_cache");
    EXPECT_EQ(*r->body, *stopped_response(warp::Stopped::Reason::kDeadline).body);
  }
  EXPECT_FALSE(cache.get("v1|/a|q", t0 + 5000ms));
  EXPECT_FALSE(cache.get("v2|/a|q", t0)) << "another image version is another request";
}

TEST(FailureCache, KeepsOneRetryAfterAndNoLogDetail) {
  FailureCache cache(2000ms, 1 << 20);
  const Clock::time_point t0 = Clock::now();
  cache.put("k", internal_error_response("cannot read /srv/x.tif"), t0);
  const auto r = cache.get("k", t0);
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, 500);
  EXPECT_TRUE(r->log_detail.empty()) << "logged once, when it happened";
  int retry_afters = 0;
  for (const auto& h : r->headers) retry_afters += h.first == "Retry-After";
  EXPECT_EQ(retry_afters, 1);
  // A remembered 503 had its own Retry-After: 1; the window's replaces it.
  cache.put("s", stopped_response(warp::Stopped::Reason::kDeadline), t0);
  retry_afters = 0;
  for (const auto& h : cache.get("s", t0)->headers) retry_afters += h.first == "Retry-After";
  EXPECT_EQ(retry_afters, 1);
  EXPECT_EQ(retry_after(*cache.get("s", t0)), "2");
}

TEST(FailureCache, AFloodOfDistinctFailuresCostsBoundedMemory) {
  constexpr std::size_t kBytes = 64 << 10;
  FailureCache cache(60000ms, kBytes);
  const Clock::time_point t0 = Clock::now();
  for (int i = 0; i < 10000; ++i) cache.put("v1|/view?cx=" + std::to_string(i), internal_error_response(""), t0);
  EXPECT_LE(cache.bytes(), kBytes);
  EXPECT_TRUE(cache.get("v1|/view?cx=9999", t0)) << "the newest are kept";
  EXPECT_FALSE(cache.get("v1|/view?cx=0", t0)) << "the oldest went first";
}

TEST(FailureCache, AWindowOfZeroRemembersNothing) {
  FailureCache cache(0ms, 1 << 20);
  cache.put("k", internal_error_response(""));
  EXPECT_FALSE(cache.get("k"));
  EXPECT_EQ(cache.bytes(), 0u);
}

}  // namespace
}  // namespace zoomwarp::api
