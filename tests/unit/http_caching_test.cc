// If-None-Match (weak comparison) and If-Match (strong comparison) over entity-tag lists,
// RFC 9110 §13.1.1-2.
#include <gtest/gtest.h>

#include "api/http_caching.h"

namespace zoomwarp::api {
namespace {

const std::string kTag = "\"v1-00ff\"";

TEST(EntityTags, IfNoneMatchComparesWeaklyOverLists) {
  EXPECT_TRUE(if_none_match_matches(kTag, kTag));
  EXPECT_TRUE(if_none_match_matches("W/" + kTag, kTag));
  EXPECT_TRUE(if_none_match_matches("\"a\", W/\"b\" ,\t" + kTag, kTag));
  EXPECT_TRUE(if_none_match_matches(" * ", kTag));
  EXPECT_FALSE(if_none_match_matches("\"v1-00fe\"", kTag));
  EXPECT_FALSE(if_none_match_matches("v1-00ff", kTag)) << "unquoted is malformed";
  EXPECT_FALSE(if_none_match_matches("", kTag));
}

TEST(EntityTags, IfMatchComparesStronglyOverLists) {
  EXPECT_TRUE(if_match_matches(kTag, kTag));
  EXPECT_TRUE(if_match_matches("\"a\", " + kTag, kTag));
  EXPECT_TRUE(if_match_matches("*", kTag));
  EXPECT_FALSE(if_match_matches("W/" + kTag, kTag)) << "a weak tag never matches strongly";
  EXPECT_FALSE(if_match_matches("\"a\", W/" + kTag, kTag));
  EXPECT_FALSE(if_match_matches("\"a\"", kTag));
}

TEST(EntityTags, QuotedCommasAndMalformedLists) {
  EXPECT_TRUE(if_match_matches("\"x,y\", \"a,b\"", "\"a,b\""));
  EXPECT_FALSE(if_match_matches("\"x,y\"", "\"y\""));
  EXPECT_FALSE(if_match_matches("\"unterminated, " + kTag, kTag));
  EXPECT_FALSE(if_match_matches(kTag + "junk", kTag));
  EXPECT_FALSE(if_match_matches("W/", kTag));
  EXPECT_FALSE(if_none_match_matches("*, " + kTag + "x", kTag)) << "* only on its own";
}

}  // namespace
}  // namespace zoomwarp::api
