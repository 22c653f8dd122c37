// The deflated payload every model file kind uses (warp/analysis/deflated_payload.h, issue 28):
// it round trips, and a stream that does not inflate to exactly the size it states, or states
// more than the limit, is a ModelFileError naming the file.
#include <gtest/gtest.h>

#include <string>

#include "warp/analysis/deflated_payload.h"
#include "warp/analysis/model_file.h"

namespace zoomwarp {
namespace {

TEST(DeflatedPayload, RoundTripsAndRefusesAStreamOfAnotherSize) {
  std::string payload;
  for (int i = 0; i < 100000; ++i) payload.push_back(char(i % 7 == 0 ? i : 3));
  const std::string d = warp::deflated(payload);
  EXPECT_LT(d.size(), payload.size() / 4);
  EXPECT_EQ(warp::inflated("f.bin", d), payload);
  EXPECT_EQ(warp::inflated("f.bin", warp::deflated("")), "");
  std::string larger = d;
  larger[0] = char(larger[0] + 1);  // states one byte more than the stream holds
  EXPECT_THROW(warp::inflated("f.bin", larger), warp::ModelFileError);
  EXPECT_THROW(warp::inflated("f.bin", d, payload.size() - 1), warp::ModelFileError) << "over the limit";
  EXPECT_THROW(warp::inflated("f.bin", d.substr(0, d.size() / 2)), warp::ModelFileError);
  try {
    warp::inflated("f.bin", "abc");
    ADD_FAILURE();
  } catch (const warp::ModelFileError& e) {
    EXPECT_EQ(e.file(), "f.bin");
  }
}

}  // namespace
}  // namespace zoomwarp
