// api::ViewQuery::canonical(), the key of a view in the response cache and in its ETag: a client
// or proxy holding an ETag from an earlier version of the server revalidates it with a 304 only
// if the key is written exactly as before (numbers as printf's %.17g).
#include <gtest/gtest.h>

#include "api/view_query.h"

namespace zoomwarp {
namespace {

std::string key(const std::string& query) {
  return api::parse_view_query(query, api::ViewRoute::kMesh, 6028, 3391).canonical();
}

TEST(ViewQueryKey, IsWrittenAsEarlierVersionsWroteIt) {
  // The line set is named as it is asked for; auto is the default since issue 30.
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7&lines=curator"),
            "icaz|default|curator|geometric|z=0.10000000000000001|c=1000.5,7|s=480x360|jpg|q=0");
  EXPECT_EQ(key("w=480&h=360&zoom=0.1&cx=1000.5&cy=7"), "icaz|default|auto|geometric|z=0.10000000000000001|c=1000.5,7|s=480x360|jpg|q=0");
  EXPECT_EQ(key("w=360&h=640&zoom=0.123456789&cx=3000&cy=1000&from_zoom=0.3&from_cx=2999.75&lines=none"),
            "icaz|default|none|geometric|z=0.123456789|c=3000,1000|s=360x640|from=0.29999999999999999,2999.75,1000|jpg|q=0");
  // A method that takes no lines has one key for every line set.
  EXPECT_EQ(key("w=480&h=360&method=traditional&lines=none"), key("w=480&h=360&method=traditional"));
  EXPECT_EQ(key("w=480&h=360&method=seam&lines=auto"), key("w=480&h=360&method=seam&lines=curator"));
}

}  // namespace
}  // namespace zoomwarp
