// Ingest of every supported kind of source into a pyramid: formats, bit depths, channel layouts,
// EXIF orientation, and the refusals (unsupported, too large, corrupt) that must leave nothing.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iostream>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/source_compression.h"
#include "tiles/pyramid_reader.h"

namespace zoomwarp {
namespace {

using testing::TempDir;
using tiles::Raster;

struct Case {
  const char* name;
  const char* ext;
  int channels;  // of the source
  int bits;
  bool lossy = false;  // OpenImageIO writes WebP lossy only: compare with the decoded file then
};

class PyramidFormats : public ::testing::TestWithParam<Case> {};

// Stored level 0 equals the source exactly (lossless sources, stored with zip:1), in RGB or RGBA.
TEST_P(PyramidFormats, LevelZeroIsTheSourceAndLevelsHalveRoundingUp) {
  const Case c = GetParam();
  TempDir dir;
  const Raster pattern = testing::test_pattern(301, 173, c.channels);  // odd sizes: edge tiles and rounding
  const std::string file = dir.path() + "/source" + c.ext;
  testing::write_image(file, pattern, c.bits);
  const Raster source = c.lossy ? testing::load_image(file) : pattern;

  tiles::Store store(dir.path() + "/store");
  tiles::Manifest m = tiles::ingest_image(store, file, "img", {});
  EXPECT_EQ(m.width, 301);
  EXPECT_EQ(m.height, 173);
  EXPECT_EQ(m.levels, 10);  // 301 -> 151 -> 76 -> 38 -> 19 -> 10 -> 5 -> 3 -> 2 -> 1
  EXPECT_EQ(m.channels, (c.channels == 2 || c.channels == 4) ? 4 : 3);
  EXPECT_EQ(m.source_bits, c.bits);

  auto entry = store.find("img");
  ASSERT_TRUE(entry);
  tiles::PyramidReader reader(16 << 20);
  const Raster level0 = reader.read_level(*entry, 0, {0, 0, 301, 173});
  // Expected: grey expanded to RGB, alpha kept.
  Raster expected(301, 173, m.channels);
  for (std::size_t i = 0; i < std::size_t(301 * 173); ++i)
    for (int ch = 0; ch < m.channels; ++ch) {
      int from = c.channels <= 2 ? (ch < 3 ? 0 : 1) : ch;
      expected.pixels[i * m.channels + ch] = source.pixels[i * c.channels + from];
    }
  if (c.lossy) {
    // A lossy source is stored as JPEG tiles (at 90: OpenImageIO's WebP has no quality to keep).
    EXPECT_EQ(m.compression, "jpeg");
    EXPECT_GT(testing::psnr(level0, expected), 30.0) << c.name;
  } else {
    EXPECT_EQ(m.compression, "zip:1");
    EXPECT_EQ(testing::psnr(level0, expected), std::numeric_limits<double>::infinity()) << c.name;
  }

  for (int k = 1; k < m.levels; ++k) {
    const Raster lk = reader.read_level(*entry, k, {0, 0, m.level_width(k), m.level_height(k)});
    EXPECT_EQ(lk.width, (301 + (1 << k) - 1) >> k);
    EXPECT_EQ(lk.height, (173 + (1 << k) - 1) >> k);
  }
  // Level 1 is the 2×2 mean of level 0 (opaque pixels; checked on the first row's pixels, of the
  // lossless cases: JPEG tiles move both levels' pixels).
  if (c.lossy) return;
  const Raster l1 = reader.read_level(*entry, 1, {0, 0, 151, 87});
  for (int x = 0; x < 150; x += 7) {
    const int a = level0.row(0)[(2 * x) * m.channels + 1], b = level0.row(0)[(2 * x + 1) * m.channels + 1];
    const int cc = level0.row(1)[(2 * x) * m.channels + 1], d = level0.row(1)[(2 * x + 1) * m.channels + 1];
    if (m.channels == 4 && level0.row(0)[(2 * x) * 4 + 3] != level0.row(0)[(2 * x + 1) * 4 + 3]) continue;
    EXPECT_NEAR(l1.row(0)[x * m.channels + 1], (a + b + cc + d) / 4.0, 1.0) << "x=" << x;
  }
}

INSTANTIATE_TEST_SUITE_P(
    Sources, PyramidFormats,
    ::testing::Values(Case{"png_rgb8", ".png", 3, 8}, Case{"png_rgb16", ".png", 3, 16},
                      Case{"png_grey8", ".png", 1, 8}, Case{"png_grey_alpha", ".png", 2, 8},
                      Case{"png_rgba8", ".png", 4, 8}, Case{"png_rgba16", ".png", 4, 16},
                      Case{"tif_rgb8", ".tif", 3, 8}, Case{"tif_rgb16", ".tif", 3, 16},
                      Case{"tif_grey16", ".tif", 1, 16}, Case{"webp_rgb", ".webp", 3, 8, true}),
    [](const auto& info) { return std::string(info.param.name); });

// A JPEG source is stored as JPEG tiles at its own quality when that is below --tile-quality
// (90), with its own chroma subsampling, and level 0 is within 40 dB of the decoded source over
// the whole image (issue 18). Re-encoded on the source's 8×8 grid with the source's tables, the
// coefficients barely change: measured 60 dB here.
TEST(Pyramid, AJpegSourceIsStoredAsJpegTilesWithin40Decibels) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  const std::string file = testing::samples_dir() + "/boats_lake_sunset.jpg";
  const tiles::SourceCompression source = tiles::source_compression(file, "jpeg");
  ASSERT_TRUE(source.jpeg);
  tiles::Manifest m = tiles::ingest_image(store, file, "boats", {});
  EXPECT_EQ(m.width, 2560);
  EXPECT_EQ(m.height, 1600);
  EXPECT_EQ(m.source_format, "jpeg");
  EXPECT_EQ(m.compression, "jpeg");
  EXPECT_EQ(m.jpeg.quality, std::min(90, source.jpeg->quality));
  EXPECT_EQ(m.jpeg.chroma_h, source.jpeg->chroma_h);
  EXPECT_EQ(m.jpeg.chroma_v, source.jpeg->chroma_v);
  tiles::PyramidReader reader(64 << 20);
  const Raster stored = reader.read_level(*store.find("boats"), 0, {0, 0, 2560, 1600});
  const double db = testing::psnr(stored, testing::load_image(file));
  std::cout << "[ figures ] boats_lake_sunset.jpg (quality " << source.jpeg->quality << ") stored at quality "
            << m.jpeg.quality << ": level 0 PSNR " << db << " dB\n";
  EXPECT_GE(db, 40.0);
}

// The same source with a lossless compression asked for is stored exactly as decoded.
TEST(Pyramid, AJpegSourceStoredLosslesslyIsItsDecodedPixels) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  const std::string file = testing::samples_dir() + "/boats_lake_sunset.jpg";
  tiles::IngestOptions options;
  options.pyramid.compression = "zip:1";
  EXPECT_EQ(tiles::ingest_image(store, file, "boats", options).compression, "zip:1");
  tiles::PyramidReader reader(64 << 20);
  const Raster stored = reader.read_level(*store.find("boats"), 0, {1000, 700, 300, 200});
  const Raster reference = testing::crop(testing::load_image(file), {1000, 700, 300, 200});
  EXPECT_EQ(testing::psnr(stored, reference), std::numeric_limits<double>::infinity());
}

// A quality-97 JPEG is stored at --tile-quality (here the default 90) and still within 40 dB; a
// lossless source asked to be stored as JPEG is stored at that quality with 4:2:0, and within
// 40 dB of itself (a photograph; the synthetic test pattern's sharp edges are JPEG's worst case).
TEST(Pyramid, TileQualityIsAnUpperBound) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  const Raster photo = testing::crop(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"),
                                     {600, 400, 700, 500});
  const std::string fine = dir.path() + "/fine.jpg", png = dir.path() + "/photo.png";
  testing::write_image(fine, photo, 8, 1, 97);
  testing::write_image(png, photo);
  ASSERT_EQ(tiles::source_compression(fine, "jpeg").jpeg->quality, 97);

  const tiles::Manifest m = tiles::ingest_image(store, fine, "fine", {});
  EXPECT_EQ(m.compression, "jpeg");
  EXPECT_EQ(m.jpeg.quality, 90);
  tiles::PyramidReader reader(16 << 20);
  EXPECT_GE(testing::psnr(reader.read_level(*store.find("fine"), 0, {0, 0, 700, 500}), testing::load_image(fine)), 40.0);

  EXPECT_EQ(tiles::ingest_image(store, png, "png", {}).compression, "zip:1");  // auto: lossless stays lossless
  tiles::IngestOptions as_jpeg;
  as_jpeg.pyramid.compression = "jpeg";
  as_jpeg.pyramid.jpeg_quality = 92;
  const tiles::Manifest j = tiles::ingest_image(store, png, "png-jpeg", as_jpeg);
  EXPECT_EQ(j.compression, "jpeg");
  EXPECT_EQ(j.jpeg, (tiles::JpegTileFormat{92, 2, 2}));
  EXPECT_GE(testing::psnr(reader.read_level(*store.find("png-jpeg"), 0, {0, 0, 700, 500}), photo), 40.0);
}

// Alpha cannot be JPEG: an RGBA source asked to be stored as JPEG keeps its alpha, losslessly.
TEST(Pyramid, AnRgbaSourceAskedForJpegIsStoredLosslessly) {
  TempDir dir;
  tiles::Store store(dir.path() + "/store");
  const Raster rgba = testing::test_pattern(300, 200, 4);
  const std::string file = dir.path() + "/rgba.png";
  testing::write_image(file, rgba);
  tiles::IngestOptions as_jpeg;
  as_jpeg.pyramid.compression = "jpeg";
  EXPECT_EQ(tiles::ingest_image(store, file, "rgba", as_jpeg).compression, "zip:1");
  tiles::PyramidReader reader(16 << 20);
  EXPECT_EQ(testing::psnr(reader.read_level(*store.find("rgba"), 0, {0, 0, 300, 200}), rgba),
            std::numeric_limits<double>::infinity());
}

// EXIF orientation 6 means "rotate 90° clockwise to display": the stored image is upright.
TEST(Pyramid, ExifOrientationIsApplied) {
  TempDir dir;
  const Raster raw = testing::test_pattern(120, 80, 3);
  for (const char* ext : {".tif", ".jpg"}) {
    const std::string file = dir.path() + "/rotated" + ext;
    testing::write_image(file, raw, 8, 6);
    tiles::Store store(dir.path() + "/store" + ext);
    tiles::Manifest m = tiles::ingest_image(store, file, "r", {});
    ASSERT_EQ(m.width, 80) << ext;
    ASSERT_EQ(m.height, 120) << ext;
    EXPECT_EQ(m.source_orientation, 6);
    tiles::PyramidReader reader(16 << 20);
    const Raster upright = reader.read_level(*store.find("r"), 0, {0, 0, 80, 120});
    Raster expected(80, 120, 3);  // new(x, y) = old(y, H - 1 - x), H = 80
    for (int y = 0; y < 120; ++y)
      for (int x = 0; x < 80; ++x)
        for (int c = 0; c < 3; ++c) expected.row(y)[x * 3 + c] = raw.row(80 - 1 - x)[y * 3 + c];
    // Stored as JPEG tiles: compared with the decoded source turned upright (by OpenImageIO),
    // which is what the tiles were made from.
    if (std::string(ext) == ".jpg") expected = testing::load_image(file);
    EXPECT_GT(testing::psnr(upright, expected), std::string(ext) == ".jpg" ? 30.0 : 1e9) << ext;
  }
}

class Refusals : public ::testing::Test {
 protected:
  TempDir dir;
  tiles::Store store{dir.path() + "/store"};

  tiles::IngestError::Kind refusal(const std::string& file, tiles::IngestOptions options = {}) {
    try {
      tiles::ingest_image(store, file, "bad", options);
    } catch (const tiles::IngestError& e) {
      EXPECT_FALSE(store.find("bad"));
      EXPECT_TRUE(std::filesystem::is_empty(dir.path() + "/store/staging")) << "staging left behind";
      EXPECT_TRUE(std::filesystem::is_empty(dir.path() + "/store/versions")) << "version left behind";
      return e.kind();
    }
    ADD_FAILURE() << "ingest of " << file << " succeeded";
    return tiles::IngestError::Kind::kIo;
  }

  std::string write_bytes(const std::string& name, const std::string& bytes) {
    const std::string p = dir.path() + "/" + name;
    std::ofstream(p, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
    return p;
  }

  std::string truncated(const std::string& source, double fraction) {
    std::ifstream in(source, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    return write_bytes("truncated_" + std::filesystem::path(source).filename().string(),
                       bytes.substr(0, std::size_t(bytes.size() * fraction)));
  }
};

TEST_F(Refusals, UnsupportedFormats) {
  EXPECT_EQ(refusal(write_bytes("a.gif", "GIF89a\x01\x00\x01\x00")), tiles::IngestError::Kind::kUnsupportedFormat);
  EXPECT_EQ(refusal(write_bytes("a.txt", "hello, I am not an image")), tiles::IngestError::Kind::kUnsupportedFormat);
  EXPECT_EQ(refusal(write_bytes("empty", "")), tiles::IngestError::Kind::kUnsupportedFormat);
}

TEST_F(Refusals, TruncatedAndCorruptImages) {
  EXPECT_EQ(refusal(truncated(testing::samples_dir() + "/boats_lake_sunset.jpg", 0.5)), tiles::IngestError::Kind::kCorrupt);
  // Found while tiles are still being compressed on other threads.
  tiles::IngestOptions threaded;
  threaded.pyramid.threads = 4;
  EXPECT_EQ(refusal(truncated(testing::samples_dir() + "/boats_lake_sunset.jpg", 0.8), threaded),
            tiles::IngestError::Kind::kCorrupt);
  EXPECT_EQ(refusal(truncated(testing::samples_dir() + "/pano_grossmugl_field_4to1.png", 0.5)),
            tiles::IngestError::Kind::kCorrupt);
  EXPECT_EQ(refusal(write_bytes("bad.jpg", std::string("\xFF\xD8\xFF\xE0", 4) + std::string(2000, '\x17'))),
            tiles::IngestError::Kind::kCorrupt);
  EXPECT_EQ(refusal(write_bytes("bad.png", std::string("\x89PNG\r\n\x1A\n", 8) + std::string(500, 'x'))),
            tiles::IngestError::Kind::kCorrupt);
}

TEST_F(Refusals, OverThePixelLimitBeforeDecoding) {
  tiles::IngestOptions options;
  options.limits.max_pixels = 2560 * 1600 - 1;
  EXPECT_EQ(refusal(testing::samples_dir() + "/boats_lake_sunset.jpg", options), tiles::IngestError::Kind::kTooLarge);
}

TEST_F(Refusals, InvalidIdIsRejectedBeforeAnyWork) {
  for (const char* id : {"", "..", "../x", "a/b", ".hidden", "a..b"})
    EXPECT_THROW(tiles::ingest_image(store, testing::samples_dir() + "/boats_lake_sunset.jpg", id, {}),
                 std::invalid_argument)
        << id;
  EXPECT_TRUE(std::filesystem::is_empty(dir.path() + "/store/staging"));
}

}  // namespace
}  // namespace zoomwarp
