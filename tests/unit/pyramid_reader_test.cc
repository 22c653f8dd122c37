// PyramidReader's statistics, which /metrics reports as the decoded-tile cache's hits and misses.
#include <gtest/gtest.h>

#include <string>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "tiles/ingest.h"
#include "tiles/pyramid_reader.h"

namespace zoomwarp {
namespace {

// A read covering 2 × 2 tiles is four lookups; reading it again finds them all in the cache.
TEST(PyramidReader, CountsLookupsAndTilesRead) {
  testing::TempDir dir;
  const std::string file = dir.path() + "/pattern.png";
  testing::write_image(file, testing::test_pattern(1000, 700, 3));
  tiles::Store store(dir.path() + "/store");
  tiles::ingest_image(store, file, "pattern", {});
  const auto entry = store.find("pattern");
  ASSERT_TRUE(entry);
  tiles::PyramidReader reader(16 << 20);

  reader.read_level(*entry, 0, {200, 100, 100, 300});  // tiles (0, 0), (0, 1), (1, 0), (1, 1) of 256 px
  const tiles::PyramidReader::Stats first = reader.stats();
  EXPECT_EQ(first.lookups, 4);
  EXPECT_EQ(first.tiles_read, 4);

  reader.read_level(*entry, 0, {200, 100, 100, 300});
  const tiles::PyramidReader::Stats second = reader.stats();
  EXPECT_EQ(second.lookups, 8);
  EXPECT_EQ(second.tiles_read, 4);  // /metrics: 4 hits, 4 misses
}

}  // namespace
}  // namespace zoomwarp
