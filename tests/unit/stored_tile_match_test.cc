// Which IIIF and Deep Zoom requests are exactly one stored JPEG tile (api/stored_tile_match.h),
// on the sample's geometry: 2560 × 1600, tiles of 256, level 1 = 1280 × 800, level 3 = 320 × 200.
#include <gtest/gtest.h>

#include "api/deepzoom.h"
#include "api/iiif.h"
#include "api/stored_tile_match.h"

namespace zoomwarp {
namespace {

using api::StoredTileRef;

tiles::Manifest jpeg_tiled() {
  tiles::Manifest m;
  m.width = 2560;
  m.height = 1600;
  m.levels = tiles::pyramid_levels(m.width, m.height);
  m.compression = "jpeg";
  return m;
}

std::optional<StoredTileRef> iiif(const tiles::Manifest& m, const char* region, const char* size,
                                  const char* rotation = "0", const char* qf = "default.jpg") {
  return api::iiif_stored_tile(m, api::plan_iiif_request(region, size, rotation, qf, m.width, m.height, {}));
}

TEST(StoredTileMatch, IiifTilesOnTheGridAtTheirLevelsSizeAreStoredTiles) {
  const tiles::Manifest m = jpeg_tiled();
  EXPECT_EQ(iiif(m, "0,0,256,256", "256,"), (StoredTileRef{0, 0, 0}));
  EXPECT_EQ(iiif(m, "768,512,256,256", "max"), (StoredTileRef{0, 3, 2}));
  EXPECT_EQ(iiif(m, "768,512,256,256", "256,256", "0", "color.jpg"),
            (StoredTileRef{0, 3, 2}));
  EXPECT_EQ(iiif(m, "512,0,512,512", "256,"), (StoredTileRef{1, 1, 0}));
  EXPECT_EQ(iiif(m, "512,0,512,512", "pct:50"), (StoredTileRef{1, 1, 0}));
  EXPECT_EQ(iiif(m, "512,0,512,512", "!256,256"), (StoredTileRef{1, 1, 0}));
  // Edge tiles: up to the image's edge, at the size of the level's clipped tile.
  EXPECT_EQ(iiif(m, "2048,1536,512,64", "256,32"), (StoredTileRef{1, 4, 3}));
  EXPECT_EQ(iiif(m, "0,1536,256,64", "256,64"), (StoredTileRef{0, 0, 6}));
  EXPECT_EQ(iiif(m, "2048,0,512,1600", "64,200"), (StoredTileRef{3, 1, 0}));
  EXPECT_EQ(iiif(m, "full", "40,25"), (StoredTileRef{6, 0, 0}));  // level 6 is one tile
  // Level 7 is 20 × 13 (12.5 rounded up): its shrink, 1600 / 13 < 128, makes the decode path read
  // level 6 and resample, so the stored tile would be another answer.
  EXPECT_FALSE(iiif(m, "full", "20,13"));
}

TEST(StoredTileMatch, IiifRequestsThatAreNotOneStoredTileAsItIs) {
  const tiles::Manifest m = jpeg_tiled();
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "90"));
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "!0"));
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "0", "gray.jpg"));
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "0", "bitonal.jpg"));
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "0", "default.png"));
  EXPECT_FALSE(iiif(m, "0,0,256,256", "256,", "0", "default.webp"));
  EXPECT_FALSE(iiif(m, "10,0,256,256", "256,"));     // off the grid
  EXPECT_FALSE(iiif(m, "0,0,256,255", "256,255"));   // part of a tile
  EXPECT_FALSE(iiif(m, "0,0,512,256", "512,"));      // two tiles
  EXPECT_FALSE(iiif(m, "0,0,256,256", "255,"));      // resampled
  EXPECT_FALSE(iiif(m, "0,0,512,512", "384,"));      // resampled from level 0
  EXPECT_FALSE(iiif(m, "256,0,512,512", "256,"));    // level 1's grid is 512 full-resolution px
  tiles::Manifest zip = jpeg_tiled();
  zip.compression = "zip:1";
  EXPECT_FALSE(iiif(zip, "0,0,256,256", "256,"));
  tiles::Manifest rgba = jpeg_tiled();
  rgba.channels = 4;
  EXPECT_FALSE(iiif(rgba, "0,0,256,256", "256,"));
}

TEST(StoredTileMatch, DeepZoomTilesOnlyWithTheStoredGrid) {
  const tiles::Manifest m = jpeg_tiled();
  const api::DziLayout stored{256, 0}, classic{};
  const int full = m.levels - 1;  // DZI level of stored level 0
  auto dzi = [&](const api::DziLayout& layout, int level, int col, int row, tiles::ImageFormat f) {
    return api::dzi_stored_tile(m, layout, *api::dzi_tile(m, layout, level, col, row), f);
  };
  EXPECT_EQ(dzi(stored, full, 3, 2, tiles::ImageFormat::kJpeg), (StoredTileRef{0, 3, 2}));
  EXPECT_EQ(dzi(stored, full, 9, 6, tiles::ImageFormat::kJpeg), (StoredTileRef{0, 9, 6}));  // bottom edge
  EXPECT_EQ(dzi(stored, full - 3, 1, 0, tiles::ImageFormat::kJpeg), (StoredTileRef{3, 1, 0}));
  EXPECT_EQ(dzi(stored, 0, 0, 0, tiles::ImageFormat::kJpeg), (StoredTileRef{full, 0, 0}));
  EXPECT_FALSE(dzi(stored, full, 3, 2, tiles::ImageFormat::kPng));
  EXPECT_FALSE(dzi(classic, full, 3, 2, tiles::ImageFormat::kJpeg));
  EXPECT_FALSE(dzi(api::DziLayout{512, 0}, full, 1, 1, tiles::ImageFormat::kJpeg));
}

}  // namespace
}  // namespace zoomwarp
