// What ingest reads from a source's own compression to choose the stored tiles' (issue 18): a
// JPEG's IJG quality from its luma table and its chroma subsampling; whether a WebP is lossy.
#include <gtest/gtest.h>
#include <turbojpeg.h>

#include <fstream>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/source_compression.h"

namespace zoomwarp {
namespace {

using testing::TempDir;

// A JPEG of the test pattern written by libjpeg-turbo at `quality` with `sampling`.
std::string write_jpeg(const std::string& path, int quality, TJSAMP sampling) {
  const tiles::Raster r = testing::test_pattern(64, 48, 3);
  tjhandle tj = tjInitCompress();
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  EXPECT_EQ(tjCompress2(tj, r.pixels.data(), r.width, 0, r.height, TJPF_RGB, &buf, &size, sampling, quality, 0), 0);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(buf), std::streamsize(size));
  tjFree(buf);
  tjDestroy(tj);
  return path;
}

TEST(SourceCompression, AJpegsQualityAndSubsamplingAreReadFromItsHeader) {
  TempDir dir;
  struct Case { int quality; TJSAMP sampling; int h, v; };
  for (const Case c : {Case{10, TJSAMP_420, 2, 2}, Case{50, TJSAMP_420, 2, 2}, Case{75, TJSAMP_422, 2, 1},
                       Case{85, TJSAMP_444, 1, 1}, Case{93, TJSAMP_420, 2, 2}, Case{100, TJSAMP_444, 1, 1}}) {
    const std::string file = write_jpeg(dir.path() + "/q" + std::to_string(c.quality) + ".jpg", c.quality, c.sampling);
    const tiles::SourceCompression s = tiles::source_compression(file, "jpeg");
    EXPECT_TRUE(s.lossy);
    ASSERT_TRUE(s.jpeg) << c.quality;
    EXPECT_EQ(*s.jpeg, (tiles::JpegTileFormat{c.quality, c.h, c.v})) << c.quality;
  }
}

// 4:1:1 cannot be stored in the tiles: 4:2:0 then. A grey JPEG (expanded to RGB) gets 4:2:0.
TEST(SourceCompression, SubsamplingTheTilesCannotStoreBecomes420) {
  TempDir dir;
  const auto grey = tiles::source_compression(write_jpeg(dir.path() + "/grey.jpg", 80, TJSAMP_GRAY), "jpeg");
  ASSERT_TRUE(grey.jpeg);
  EXPECT_EQ(*grey.jpeg, (tiles::JpegTileFormat{80, 2, 2}));
  const auto s411 = tiles::source_compression(write_jpeg(dir.path() + "/411.jpg", 80, TJSAMP_411), "jpeg");
  ASSERT_TRUE(s411.jpeg);
  EXPECT_EQ(*s411.jpeg, (tiles::JpegTileFormat{80, 2, 2}));
}

// A damaged header: lossy, no format (the decoder refuses the file later).
TEST(SourceCompression, ATruncatedJpegIsLossyWithoutAFormat) {
  TempDir dir;
  const std::string file = dir.path() + "/cut.jpg";
  std::ofstream(file, std::ios::binary).write("\xFF\xD8\xFF\xE0\x00\x10JFIF", 10);
  const tiles::SourceCompression s = tiles::source_compression(file, "jpeg");
  EXPECT_TRUE(s.lossy);
  EXPECT_FALSE(s.jpeg);
}

TEST(SourceCompression, WebpIsLossyOnlyWithAVp8Bitstream) {
  TempDir dir;
  const tiles::Raster r = testing::test_pattern(64, 48, 3);
  const std::string lossy = dir.path() + "/lossy.webp";
  testing::write_image(lossy, r, 8, 1, 80);
  EXPECT_TRUE(tiles::source_compression(lossy, "webp").lossy);
  // A hand-made lossless header (RIFF, WEBP, VP8L) and an extended one whose image is VP8L.
  const std::string vp8l = dir.path() + "/lossless.webp", vp8x = dir.path() + "/extended.webp";
  std::ofstream(vp8l, std::ios::binary).write("RIFF\x1a\0\0\0WEBPVP8L\x0d\0\0\0\x2f\0\0\0\0\0\0\0\0\0\0\0\0\0", 34);
  std::ofstream(vp8x, std::ios::binary)
      .write("RIFF\x2e\0\0\0WEBPVP8X\x0a\0\0\0\0\0\0\0\0\0\0\0\0\0VP8L\x0d\0\0\0\x2f\0\0\0\0\0\0\0\0\0\0\0\0\0", 52);
  EXPECT_FALSE(tiles::source_compression(vp8l, "webp").lossy);
  EXPECT_FALSE(tiles::source_compression(vp8x, "webp").lossy);
  EXPECT_FALSE(tiles::source_compression(dir.path() + "/lossless.png", "png").lossy);
}

}  // namespace
}  // namespace zoomwarp
