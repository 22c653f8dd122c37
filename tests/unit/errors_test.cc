// Error bodies name no file: library messages keep their sense and lose their paths.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "api/errors.h"

namespace zoomwarp::api {
namespace {

TEST(ErrorMessages, AbsolutePathsAreReplaced) {
  EXPECT_EQ(without_paths("OpenImageIO could not find a format reader for \"/srv/store/staging/vm.8087.04/upload\". Is it"),
            "OpenImageIO could not find a format reader for \"(file)\". Is it");
  EXPECT_EQ(without_paths("cannot read /var/lib/zoomwarp/versions/a@1/level_3.tif: Not a TIFF"), "cannot read (file): Not a TIFF");
  EXPECT_EQ(without_paths("/tmp/x failed (at '/a/b')"), "(file) failed (at '(file)')");
  EXPECT_EQ(without_paths("image is 3x4 and 1/2 done; w/h"), "image is 3x4 and 1/2 done; w/h") << "not paths";
}

TEST(ErrorMessages, InternalErrorsKeepTheDetailOutOfTheBody) {
  const Response r = internal_error_response("cannot open /srv/store/versions/a@1/warp_model.bin");
  EXPECT_EQ(r.status, 500);
  EXPECT_EQ(r.body->find("/srv"), std::string::npos);
  EXPECT_EQ(nlohmann::json::parse(*r.body)["error"]["code"], "internal_error");
  EXPECT_EQ(r.log_detail, "cannot open /srv/store/versions/a@1/warp_model.bin");
}

TEST(ErrorMessages, StoppedRequestsAre503WithRetryAfter) {
  for (auto [reason, code, label] : {std::tuple{warp::Stopped::Reason::kDeadline, "deadline_exceeded", "deadline"},
                                     std::tuple{warp::Stopped::Reason::kCancelled, "request_cancelled", "cancelled"}}) {
    const Response r = stopped_response(reason);
    EXPECT_EQ(r.status, 503);
    EXPECT_EQ(nlohmann::json::parse(*r.body)["error"]["code"], code);
    EXPECT_EQ(r.failure, label);
    bool retry_after = false;
    for (const auto& [name, value] : r.headers) retry_after |= name == "Retry-After" && value == "1";
    EXPECT_TRUE(retry_after);
  }
}

}  // namespace
}  // namespace zoomwarp::api
