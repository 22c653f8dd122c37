#include "tests/support/stored_tile_reference.h"

#include <gtest/gtest.h>
#include <tiffio.h>
#include <turbojpeg.h>

#include <cstdint>
#include <memory>
#include <vector>

#include "tiles/jpeg_tiles.h"

namespace zoomwarp::testing {

std::string stored_tile_jpeg(const std::string& level_path, int tx, int ty) {
  std::unique_ptr<TIFF, void (*)(TIFF*)> tif(TIFFOpen(level_path.c_str(), "r"), TIFFClose);
  EXPECT_TRUE(tif) << level_path;
  if (!tif) return "";
  std::uint32_t tile_w = 0, count = 0;
  void* tables = nullptr;
  EXPECT_TRUE(TIFFGetField(tif.get(), TIFFTAG_TILEWIDTH, &tile_w));
  EXPECT_TRUE(TIFFGetField(tif.get(), TIFFTAG_JPEGTABLES, &count, &tables));
  if (!tables || tile_w == 0) return "";
  const std::uint32_t tile = TIFFComputeTile(tif.get(), std::uint32_t(tx) * tile_w, std::uint32_t(ty) * tile_w, 0, 0);
  std::vector<std::uint8_t> raw(TIFFGetStrileByteCount(tif.get(), tile));
  EXPECT_EQ(TIFFReadRawTile(tif.get(), tile, raw.data(), tmsize_t(raw.size())), tmsize_t(raw.size()));
  const auto* t = static_cast<const std::uint8_t*>(tables);
  return tiles::complete_jpeg(std::span(t, count), raw);
}

tiles::Raster decode_jpeg_blockwise(const std::string& jpeg) {
  std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitDecompress(), tjDestroy);
  const auto* data = reinterpret_cast<const unsigned char*>(jpeg.data());
  int w = 0, h = 0, subsamp = 0, colorspace = 0;
  EXPECT_EQ(tjDecompressHeader3(tj.get(), data, jpeg.size(), &w, &h, &subsamp, &colorspace), 0);
  tiles::Raster out(w, h, 3);
  EXPECT_EQ(tjDecompress2(tj.get(), data, jpeg.size(), out.pixels.data(), w, 0, h, TJPF_RGB, TJFLAG_FASTUPSAMPLE), 0)
      << tjGetErrorStr2(tj.get());
  return out;
}

}  // namespace zoomwarp::testing
