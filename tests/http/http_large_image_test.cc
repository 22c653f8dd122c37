// A 100-megapixel image is ingested in bounded memory (streamed, never held whole, let alone as
// float) and served with the process's memory near the configured cache sizes.
#include <gtest/gtest.h>

#include <OpenImageIO/imageio.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <random>

#include "tests/support/http_client.h"
#include "tests/support/images.h"
#include "tests/support/server_process.h"

namespace zoomwarp {
namespace {

constexpr int kW = 12800, kH = 8000;  // 102.4 MP

// A mosaic of the sample photo (mirrored in every other cell), written scanline by scanline.
void write_mosaic(const std::string& path, const tiles::Raster& cell) {
  auto out = OIIO::ImageOutput::create(path);
  OIIO::ImageSpec spec(kW, kH, 3, OIIO::TypeDesc::UINT8);
  spec.attribute("Compression", "jpeg:90");
  ASSERT_TRUE(out && out->open(path, spec));
  std::vector<std::uint8_t> row(std::size_t(kW) * 3);
  for (int y = 0; y < kH; ++y) {
    const int cy = y / cell.height, sy = y % cell.height;
    for (int x = 0; x < kW; ++x) {
      const int cx = x / cell.width;
      const int sx = (cx + cy) % 2 ? cell.width - 1 - x % cell.width : x % cell.width;
      std::copy_n(cell.row(sy) + sx * 3, 3, row.data() + std::size_t(x) * 3);
    }
    ASSERT_TRUE(out->write_scanline(y, 0, OIIO::TypeDesc::UINT8, row.data()));
  }
  out->close();
}

long rss_kb(pid_t pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

TEST(LargeImage, HundredMegapixelsInBoundedMemory) {
  testing::TempDir dir;
  const std::string source = dir.path() + "/mosaic.jpg";
  const tiles::Raster cell = testing::load_image(testing::samples_dir() + "/boats_lake_sunset.jpg");
  write_mosaic(source, cell);

  const std::string store = dir.path() + "/store";
  // Debian's OpenImageIO links ~260 libraries whose start-up alone costs ~130 MB of RSS (mostly
  // shared, file-backed pages): memory is judged above that baseline.
  const long baseline_kb = testing::run_command({testing::zoomwarp_binary(), "ingest", "--help"}).max_rss_kb;
  auto ingest = testing::run_command({testing::zoomwarp_binary(), "ingest", source, "--store", store, "--id", "mosaic"});
  ASSERT_EQ(ingest.exit_code, 0) << ingest.output;
  const double raw_mb = double(kW) * kH * 3 / (1 << 20);
  const double ingest_mb = (ingest.max_rss_kb - baseline_kb) / 1024.0;
  std::printf("[ figures ] ingest of %dx%d (%.0f MB as 8-bit RGB, %.0f MB as float): peak RSS %.1f MB, "
              "%.1f MB above the process baseline of %.1f MB\n",
              kW, kH, raw_mb, raw_mb * 4, ingest.max_rss_kb / 1024.0, ingest_mb, baseline_kb / 1024.0);
  RecordProperty("ingest_peak_rss_kb", std::to_string(ingest.max_rss_kb));
  EXPECT_LT(ingest_mb, raw_mb / 4) << "ingest streams: it never holds the image, even as 8-bit";

  const int tile_cache_mb = 64, response_cache_mb = 32;
  testing::ServerProcess server(store, {"--tile-cache", std::to_string(tile_cache_mb) + "M", "--response-cache",
                                        std::to_string(response_cache_mb) + "M", "--log-requests", "0"});
  testing::HttpClient http(server.port());
  const long server_baseline_kb = rss_kb(server.pid());
  auto info = nlohmann::json::parse(http.get("/v1/images/mosaic").body);
  ASSERT_EQ(info["width"], kW);
  ASSERT_EQ(info["levels"], 15);

  // Full-resolution tiles across the whole image, every level's tiles, and some IIIF regions:
  // far more decoded data than the caches hold.
  std::mt19937 rng(7);
  std::size_t bytes = 0;
  long peak = 0;
  for (int i = 0; i < 600; ++i) {
    const int col = int(rng() % 51), row = int(rng() % 32);
    auto r = http.get("/dzi/mosaic_files/14/" + std::to_string(col) + "_" + std::to_string(row) + ".jpg");
    ASSERT_EQ(r.status, 200);
    bytes += r.body.size();
    if (i % 50 == 0) peak = std::max(peak, rss_kb(server.pid()));
  }
  for (int level = 8; level <= 13; ++level) {
    const int n = (((kW + (1 << (14 - level)) - 1) >> (14 - level)) + 253) / 254;
    for (int col = 0; col < n; col += 3) ASSERT_EQ(http.get("/dzi/mosaic_files/" + std::to_string(level) + "/" + std::to_string(col) + "_0.jpg").status, 200);
  }
  auto full = http.get("/iiif/3/mosaic/full/!1024,1024/0/default.jpg");
  ASSERT_EQ(full.status, 200);
  auto thumb = testing::decode_image(full.body);
  EXPECT_EQ(thumb.width, 1024);
  EXPECT_EQ(thumb.height, 640);
  // Pixels: a full-resolution tile is the mosaic cell it shows.
  auto tile = testing::decode_image(http.get("/dzi/mosaic_files/14/1_1.png").body);
  EXPECT_GT(testing::psnr(tile, testing::crop(cell, {253, 253, 256, 256})), 30.0);

  peak = std::max(peak, rss_kb(server.pid()));
  const double growth_mb = (peak - server_baseline_kb) / 1024.0;
  std::printf("[ figures ] served %zu MB of tiles; server RSS peak %.1f MB, %.1f MB above its idle %.1f MB, "
              "with caches of %d + %d MB\n",
              bytes >> 20, peak / 1024.0, growth_mb, server_baseline_kb / 1024.0, tile_cache_mb, response_cache_mb);
  RecordProperty("serve_peak_rss_kb", std::to_string(peak));
  EXPECT_LT(growth_mb, tile_cache_mb + response_cache_mb + 48) << "RSS stays near the cache sizes";
}

}  // namespace
}  // namespace zoomwarp
