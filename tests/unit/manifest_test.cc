// manifest.json's round trip: the source's SHA-256 (what `zoomwarp ingest` skips unchanged files
// by) is kept, optional, and never a reason to refuse an image.
#include <gtest/gtest.h>

#include <string>

#include "tiles/manifest.h"

namespace zoomwarp {
namespace {

tiles::Manifest manifest() {
  tiles::Manifest m;
  m.id = "a";
  m.version = "v1";
  m.width = 100;
  m.height = 50;
  m.levels = tiles::pyramid_levels(100, 50);
  m.compression = "zip:1";
  m.source_format = "png";
  m.source_bytes = 1234;
  return m;
}

const std::string kDigest = "9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08";

TEST(Manifest, SourceDigestRoundTrips) {
  tiles::Manifest m = manifest();
  m.source_sha256 = kDigest;
  const std::string json = tiles::manifest_to_json(m);
  EXPECT_NE(json.find("\"sha256\": \"" + kDigest + "\""), std::string::npos) << json;
  const tiles::Manifest back = tiles::manifest_from_json(json);
  EXPECT_EQ(back.source_sha256, kDigest);
  EXPECT_EQ(back.source_bytes, 1234);
}

TEST(Manifest, WithoutSourceDigestStillParses) {
  const std::string json = tiles::manifest_to_json(manifest());
  EXPECT_EQ(json.find("sha256"), std::string::npos) << "no digest, no member: " << json;
  const tiles::Manifest back = tiles::manifest_from_json(json);
  EXPECT_EQ(back.source_sha256, "");
  EXPECT_EQ(back.width, 100);
}

TEST(Manifest, MalformedSourceDigestIsReadAsUnknown) {
  for (const std::string& bad : {std::string("abc"), kDigest.substr(1) + "G", std::string(64, 'A')}) {
    tiles::Manifest m = manifest();
    m.source_sha256 = bad;
    EXPECT_EQ(tiles::manifest_from_json(tiles::manifest_to_json(m)).source_sha256, "") << bad;
  }
}

}  // namespace
}  // namespace zoomwarp
