// api::ViewQuery::canonical(), the key of a view in the response cache and in its ETag: a client
// or proxy holding an ETag from an earlier version of the server revalidates it with a 304 only
// if the key is written exactly as before (numbers as printf's %.17g).
#include <gtest/gtest.h>

#include "api/errors.h"
#include "api/view_query.h"

namespace zoomwarp {
namespace {

std::string key(const std::string& query) {
  return api::parse_view_query(query, api::ViewRoute::kMesh, 6028, 3391).canonical();
}

TEST(ViewQueryKey, IsWrittenAsEarlierVersionsWroteIt) {
  // The line set is named as it is asked for; auto is the default since issue 30. fit=warp draws
  // the views of before fit= (issue 41), under the keys of then.
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7&lines=curator&fit=warp"),
            "icaz|default|curator|geometric|z=0.10000000000000001|c=1000.5,7|s=480x360|jpg|q=0");
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7&fit=warp"),
            "icaz|default|auto|geometric|z=0.10000000000000001|c=1000.5,7|s=480x360|jpg|q=0");
  EXPECT_EQ(key("w=360&h=640&zoom=0.123456789&cx=3000&cy=1000&from_zoom=0.3&from_cx=2999.75&lines=none&fit=warp"),
            "icaz|default|none|geometric|z=0.123456789|c=3000,1000|s=360x640|from=0.29999999999999999,2999.75,1000|jpg|q=0");
  // fit=auto, the default, and its budget are part of the key; so are crop and pad.
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7"),
            "icaz|default|auto|geometric|z=0.10000000000000001|c=1000.5,7|s=480x360|fit=auto,1.3999999999999999|jpg|q=0");
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7"), key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7&fit=auto&max_distortion=1.4"));
  EXPECT_EQ(key("w=480&h=360&fit=auto&max_distortion=2"), key("w=480&h=360&fit=auto&max_distortion=2.0"));
  EXPECT_NE(key("w=480&h=360&fit=auto&max_distortion=2"), key("w=480&h=360&fit=auto"));
  EXPECT_NE(key("w=480&h=360&fit=crop"), key("w=480&h=360&fit=pad"));
  // A method that takes no lines has one key for every line set.
  EXPECT_EQ(key("w=480&h=360&method=traditional&lines=none"), key("w=480&h=360&method=traditional"));
  EXPECT_EQ(key("w=480&h=360&method=seam&lines=auto"), key("w=480&h=360&method=seam&lines=curator"));
}

// fit= and max_distortion= are checked as strictly as every other parameter: a 400 that names the
// accepted values, never a guess.
TEST(ViewQueryFit, BadValuesAreRefusedWithTheAcceptedRange) {
  const auto refused = [](const std::string& query) -> std::string {
    try {
      api::parse_view_query(query, api::ViewRoute::kViewport, 6028, 3391);
    } catch (const api::ApiError& e) {
      EXPECT_EQ(e.status(), 400) << query;
      return e.what();
    }
    ADD_FAILURE() << query << " was accepted";
    return "";
  };
  EXPECT_NE(refused("w=360&h=640&fit=stretch").find("auto, warp, crop or pad"), std::string::npos);
  EXPECT_NE(refused("w=360&h=640&fit=").find("auto, warp, crop or pad"), std::string::npos);
  EXPECT_NE(refused("w=360&h=640&fit=auto&fit=crop").find("twice"), std::string::npos);
  for (const char* bad : {"0.99", "0", "-1", "8.01", "1e9", "nan", "inf", "1.5x", ""})
    EXPECT_NE(refused(std::string("w=360&h=640&max_distortion=") + bad).find("max_distortion"), std::string::npos) << bad;
  for (const char* fit : {"auto", "warp", "crop", "pad"})
    EXPECT_EQ(warp::fit_name(api::parse_view_query(std::string("w=360&h=640&fit=") + fit, api::ViewRoute::kMesh, 10, 10).fit.fit), fit);
  EXPECT_EQ(api::parse_view_query("w=360&h=640&max_distortion=1", api::ViewRoute::kMesh, 10, 10).fit.max_distortion, 1.0);
  EXPECT_EQ(api::parse_view_query("w=360&h=640&max_distortion=8", api::ViewRoute::kMesh, 10, 10).fit.max_distortion, 8.0);
}

}  // namespace
}  // namespace zoomwarp
