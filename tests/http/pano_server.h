// A server on a fresh store with the 4:1 panorama (samples/pano_grossmugl_field_4to1.png) uploaded
// as image "pano": the fixture of the tests that need views heavy enough to run out of time
// (http_deadline_test.cc, http_failure_cache_test.cc, http_poisonable_test.cc).
#pragma once

#include <gtest/gtest.h>

#include <optional>
#include <string>
#include <vector>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp::testing {

class PanoServer : public ::testing::Test {
 protected:
  // Starts `executable` (the shipped zoomwarp unless given) with `args`, writes open, and uploads
  // the panorama with ICAZ's model (--analyses icaz: these tests are about views that run out of
  // time, not about a first view waiting for its analysis); fails the test if the upload is not 201.
  void start(std::vector<std::string> args, const ServerExecutable& executable = {}) {
    args.insert(args.begin(), {"--analyses", "icaz"});
    server_.emplace(dir_.path() + "/store", args, ServerProcess::Writes::kOpen, executable);
    ASSERT_EQ(HttpClient(port())
                  .request("POST", "/v1/images?id=pano", read_file(samples_dir() + "/pano_grossmugl_field_4to1.png"))
                  .status,
              201);
  }
  int port() const { return server_->port(); }

  TempDir dir_;
  std::optional<ServerProcess> server_;
};

}  // namespace zoomwarp::testing
