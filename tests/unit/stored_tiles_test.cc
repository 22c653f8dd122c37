// tiles::StoredTiles against the level files read independently with libtiff
// (tests/support/stored_tile_reference.h): the sample JPEG (2560 × 1600) ingested with its default,
// JPEG tiles.
#include <gtest/gtest.h>

#include <fstream>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tests/support/stored_tile_reference.h"
#include "tiles/ingest.h"
#include "tiles/stored_tiles.h"

namespace zoomwarp {
namespace {

class StoredTilesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    store_ = new tiles::Store(dir_->path() + "/store");
    tiles::ingest_image(*store_, testing::samples_dir() + "/boats_lake_sunset.jpg", "boats", {});
  }
  static void TearDownTestSuite() {
    delete store_;
    delete dir_;
  }
  std::shared_ptr<const tiles::ImageEntry> boats() const { return store_->find("boats"); }

  static testing::TempDir* dir_;
  static tiles::Store* store_;
};
testing::TempDir* StoredTilesTest::dir_ = nullptr;
tiles::Store* StoredTilesTest::store_ = nullptr;

TEST_F(StoredTilesTest, AnInteriorTileIsTheTablesAndTheStoredBytes) {
  const auto e = boats();
  ASSERT_TRUE(tiles::has_jpeg_tiles(e->manifest)) << e->manifest.compression;
  tiles::StoredTiles stored;
  EXPECT_TRUE(stored.jpeg_tile(*e, 0, 3, 2) == testing::stored_tile_jpeg(e->level_path(0), 3, 2));
  EXPECT_TRUE(stored.jpeg_tile(*e, 2, 1, 0) == testing::stored_tile_jpeg(e->level_path(2), 1, 0));  // level 2: 640 × 400
}

// Level 3 is 320 × 200: tile (1, 0) is 64 × 200 of a stored 256 × 256; level 6 (40 × 25) is one
// tile. The crop keeps the stored blocks: its pixels are the whole tile's.
TEST_F(StoredTilesTest, EdgeTilesAreCroppedToTheirSizeWithTheStoredPixels) {
  const auto e = boats();
  tiles::StoredTiles stored;
  struct Case {
    int level, tx, ty, w, h;
  };
  for (const Case c : {Case{3, 1, 0, 64, 200}, Case{0, 9, 6, 256, 64}, Case{6, 0, 0, 40, 25}}) {
    SCOPED_TRACE(c.level);
    const tiles::Raster got = testing::decode_jpeg_blockwise(stored.jpeg_tile(*e, c.level, c.tx, c.ty));
    ASSERT_EQ(got.width, c.w);
    ASSERT_EQ(got.height, c.h);
    const tiles::Raster whole = testing::decode_jpeg_blockwise(testing::stored_tile_jpeg(e->level_path(c.level), c.tx, c.ty));
    EXPECT_TRUE(got.pixels == testing::crop(whole, {0, 0, c.w, c.h}).pixels);
  }
}

TEST_F(StoredTilesTest, TilesThatDoNotExistAndZipImagesAreRefused) {
  const auto e = boats();
  tiles::StoredTiles stored;
  EXPECT_THROW(stored.jpeg_tile(*e, 0, 10, 0), std::invalid_argument);
  EXPECT_THROW(stored.jpeg_tile(*e, e->manifest.levels, 0, 0), std::invalid_argument);
  EXPECT_THROW(stored.jpeg_tile(*e, 0, -1, 0), std::invalid_argument);
  const std::string png = dir_->path() + "/pattern.png";
  testing::write_image(png, testing::test_pattern(600, 400, 3));
  tiles::ingest_image(*store_, png, "pattern", {});
  const auto zip = store_->find("pattern");
  EXPECT_FALSE(tiles::has_jpeg_tiles(zip->manifest)) << "a lossless source stays lossless";
  EXPECT_THROW(stored.jpeg_tile(*zip, 0, 0, 0), std::invalid_argument);
}

TEST_F(StoredTilesTest, ADamagedLevelFileIsAReadError) {
  testing::TempDir copy;
  const auto e = boats();
  tiles::ImageEntry damaged = *e;
  damaged.files = tiles::folder_files(copy.path());
  for (int k = 0; k < e->manifest.levels; ++k) {
    std::ifstream in(e->level_path(k), std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), {});
    if (k == 1) bytes.resize(bytes.size() / 2);  // the tiles' bytes end half-way
    if (k == 2) bytes.replace(0, 4, "JUNK");
    std::ofstream(damaged.level_path(k), std::ios::binary) << bytes;
  }
  tiles::StoredTiles stored;
  EXPECT_NO_THROW(stored.jpeg_tile(damaged, 0, 0, 0));
  EXPECT_THROW(stored.jpeg_tile(damaged, 1, 4, 3), std::runtime_error);
  // runtime_error, never invalid_argument (a logic_error): the router answers 500, not 400.
  EXPECT_THROW(stored.jpeg_tile(damaged, 2, 0, 0), std::runtime_error);
}

TEST_F(StoredTilesTest, AtMostTheGivenNumberOfFilesStayOpen) {
  const auto e = boats();
  tiles::StoredTiles stored(2);
  for (int k = 0; k < 4; ++k) stored.jpeg_tile(*e, k, 0, 0);
  EXPECT_EQ(stored.open_files(), 2u);
  EXPECT_TRUE(stored.jpeg_tile(*e, 0, 3, 2) == testing::stored_tile_jpeg(e->level_path(0), 3, 2)) << "reopened";
}

}  // namespace
}  // namespace zoomwarp
