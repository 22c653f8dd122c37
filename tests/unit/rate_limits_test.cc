// Upload rate limits (api/rate_limits.h): token buckets per client, Retry-After, bounded memory.
#include <gtest/gtest.h>

#include "api/rate_limits.h"

namespace zoomwarp {
namespace {

using api::RateLimits;
using std::chrono::seconds;
const RateLimits::Clock::time_point t0{};

TEST(RateLimits, UploadsPerMinuteBurstThenRefill) {
  RateLimits limits({.uploads_per_minute = 3});
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(limits.admit("a", 10, t0)) << i;
  const auto refusal = limits.admit("a", 10, t0);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->limit, "uploads_per_minute");
  EXPECT_EQ(refusal->retry_after_seconds, 20) << "one upload frees every 60/3 s";
  EXPECT_TRUE(limits.admit("a", 10, t0 + seconds(19))) << "a refusal takes nothing, and 19 s is not enough";
  EXPECT_FALSE(limits.admit("a", 10, t0 + seconds(20)));
  EXPECT_FALSE(limits.admit("b", 10, t0)) << "another client has its own budget";
}

TEST(RateLimits, BytesPerDay) {
  RateLimits limits({.bytes_per_day = 86400});  // 1 byte per second
  EXPECT_FALSE(limits.admit("a", 80000, t0));
  const auto refusal = limits.admit("a", 10000, t0);
  ASSERT_TRUE(refusal);
  EXPECT_EQ(refusal->limit, "bytes_per_day");
  EXPECT_EQ(refusal->retry_after_seconds, 10000 - 6400);
  EXPECT_FALSE(limits.admit("a", 10000, t0 + seconds(3600)));
  const auto never = limits.admit("b", 100000, t0);
  ASSERT_TRUE(never) << "larger than a whole day's budget";
  EXPECT_EQ(never->retry_after_seconds, 86400);
}

TEST(RateLimits, NoLimitsTrackNobody) {
  RateLimits limits({});
  for (int i = 0; i < 100; ++i) EXPECT_FALSE(limits.admit(std::to_string(i), 1 << 30, t0));
  EXPECT_EQ(limits.tracked_clients(), 0u);
}

TEST(RateLimits, MemoryIsBounded) {
  RateLimits limits({.uploads_per_minute = 1, .max_clients = 4});
  for (int i = 0; i < 4; ++i) EXPECT_FALSE(limits.admit("c" + std::to_string(i), 1, t0 + seconds(i)));
  // All four are limited: a fifth client evicts the one seen longest ago.
  EXPECT_FALSE(limits.admit("new", 1, t0 + seconds(4)));
  EXPECT_EQ(limits.tracked_clients(), 4u);
  EXPECT_FALSE(limits.admit("c0", 1, t0 + seconds(5))) << "c0 was forgotten, so it starts afresh";
  EXPECT_TRUE(limits.admit("c3", 1, t0 + seconds(5))) << "c3 is still remembered";
  // A minute later everyone has refilled: room is made by forgetting those, not the limited.
  for (int i = 0; i < 10; ++i) EXPECT_FALSE(limits.admit("later" + std::to_string(i), 1, t0 + seconds(100 + i)));
  EXPECT_LE(limits.tracked_clients(), 4u);
}

}  // namespace
}  // namespace zoomwarp
