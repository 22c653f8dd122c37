// Answer encoders (tiles/encode.h) for the layouts a view or an IIIF request produces: grey, grey
// and alpha, RGB, RGBA. AVIF (issue 31) is decoded by OpenImageIO's own reader (libheif), JPEG XL
// by libjxl's decoder, and each must give back the picture, and its alpha, with no more than its
// quantizer's loss.
#include <gtest/gtest.h>

#include <stdexcept>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/encode.h"

namespace zoomwarp {
namespace {

// The sample at 320×200 with `channels` channels: grey (1, 2) or RGB (3, 4), and with 2 and 4 a
// ramp of alpha across the picture.
tiles::Raster layout(int channels) {
  static const tiles::Raster photo =
      testing::resize(testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg"), 320, 200);
  tiles::Raster source = channels >= 3 ? photo : testing::take_channels(photo, 1);
  if (channels == 1 || channels == 3) return source;
  tiles::Raster with_alpha(source.width, source.height, source.channels + 1);
  for (int y = 0; y < source.height; ++y)
    for (int x = 0; x < source.width; ++x) {
      const std::size_t i = std::size_t(y) * source.width + x;
      for (int c = 0; c < source.channels; ++c) with_alpha.pixels[i * with_alpha.channels + c] = source.pixels[i * source.channels + c];
      with_alpha.pixels[i * with_alpha.channels + source.channels] = std::uint8_t(255 * x / (source.width - 1));
    }
  return with_alpha;
}

TEST(Encode, AvifKeepsThePictureAndItsAlphaInEveryLayout) {
  for (int channels : {1, 2, 3, 4}) {
    SCOPED_TRACE(channels);
    const tiles::Raster source = layout(channels);
    tiles::EncodeOptions high;
    high.avif_quality = 90;
    const tiles::Raster decoded = testing::decode_image(tiles::encode_image(source, tiles::ImageFormat::kAvif, high));
    ASSERT_EQ(decoded.width, source.width);
    ASSERT_EQ(decoded.height, source.height);
    const bool alpha = channels == 2 || channels == 4;
    ASSERT_EQ(decoded.channels, alpha ? 4 : 3) << "grey is encoded as RGB";
    const int colours = channels <= 2 ? 1 : 3;  // grey comes back in R, G and B alike: R is compared
    EXPECT_GE(testing::psnr(testing::take_channels(decoded, colours), testing::take_channels(source, colours)), 35.0);
    if (alpha) {
      for (int x = 0; x < source.width; x += 37) {
        EXPECT_EQ(decoded.pixels[std::size_t(x) * 4 + 3], source.pixels[std::size_t(x) * source.channels + source.channels - 1])
            << "alpha is lossless, x " << x;
      }
    }
  }
}

TEST(Encode, JxlKeepsThePictureAndItsAlphaInEveryLayout) {
  for (int channels : {1, 2, 3, 4}) {
    SCOPED_TRACE(channels);
    const tiles::Raster source = layout(channels);
    tiles::EncodeOptions high;
    high.jxl_quality = 90;
    const std::string bytes = tiles::encode_image(source, tiles::ImageFormat::kJxl, high);
    ASSERT_EQ(bytes.rfind("\xFF\x0A", 0), 0u) << "a bare JPEG XL codestream";
    const tiles::Raster decoded = testing::decode_image(bytes);
    ASSERT_EQ(decoded.width, source.width);
    ASSERT_EQ(decoded.height, source.height);
    ASSERT_EQ(decoded.channels, channels) << "grey stays grey";
    const bool alpha = channels == 2 || channels == 4;
    const int colours = channels <= 2 ? 1 : 3;
    EXPECT_GE(testing::psnr(testing::take_channels(decoded, colours), testing::take_channels(source, colours)), 34.0);
    if (alpha) {
      for (int x = 0; x < source.width; x += 37)
        EXPECT_NEAR(decoded.pixels[std::size_t(x) * channels + channels - 1], source.pixels[std::size_t(x) * channels + channels - 1], 1)
            << "alpha, x " << x;
    }
  }
}

TEST(Encode, JxlQualityTradesBytesForFidelity) {
  const tiles::Raster source = layout(3);
  tiles::EncodeOptions low, high;
  low.jxl_quality = 50;
  high.jxl_quality = 95;
  const std::string small = tiles::encode_image(source, tiles::ImageFormat::kJxl, low);
  const std::string large = tiles::encode_image(source, tiles::ImageFormat::kJxl, high);
  EXPECT_LT(small.size() * 2, large.size());
  EXPECT_LT(testing::psnr(testing::decode_image(small), source) + 5, testing::psnr(testing::decode_image(large), source));
}

TEST(Encode, AJxlLargerThanServedIsRefused) {
  EXPECT_THROW(tiles::encode_image(tiles::Raster(2, tiles::kJxlMaxDimension + 1, 3), tiles::ImageFormat::kJxl, {}),
               std::invalid_argument);
}

TEST(Encode, AnAvifLargerThanServedIsRefused) {
  EXPECT_THROW(tiles::encode_image(tiles::Raster(tiles::kAvifMaxDimension + 1, 2, 3), tiles::ImageFormat::kAvif, {}),
               std::invalid_argument);
}

}  // namespace
}  // namespace zoomwarp
