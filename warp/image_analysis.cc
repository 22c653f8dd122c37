#include "warp/image_analysis.h"

#include <cstring>
#include <fstream>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {
constexpr char kMagic[8] = {'Z', 'W', 'S', 'I', 'G', '1', 0, 0};
}

tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader) {
  const tiles::Manifest& m = image.manifest;
  int k = 0;
  while (k + 1 < m.levels && std::max(m.level_width(k), m.level_height(k)) > kSignificanceMaxSide) ++k;
  return reader.read_level(image, k, {0, 0, m.level_width(k), m.level_height(k)});
}

void write_image_analysis(const tiles::ImageEntry& image) {
  tiles::PyramidReader reader(32 << 20);  // its own small cache: staged files are about to move
  const SignificanceMap map = compute_significance(read_reduced_image(image, reader), image.manifest.width);
  const std::string path = image.dir + "/" + kSignificanceFile;
  std::ofstream out(path, std::ios::binary);
  const std::int32_t size[2] = {map.width, map.height};
  out.write(kMagic, sizeof kMagic);
  out.write(reinterpret_cast<const char*>(size), sizeof size);
  out.write(reinterpret_cast<const char*>(&map.scale), sizeof map.scale);
  out.write(reinterpret_cast<const char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  if (!out.flush()) throw std::runtime_error("cannot write " + path);
}

SignificanceMap read_significance(const tiles::ImageEntry& image) {
  const std::string path = image.dir + "/" + kSignificanceFile;
  std::ifstream in(path, std::ios::binary);
  char magic[8];
  std::int32_t size[2];
  SignificanceMap map;
  in.read(magic, sizeof magic);
  in.read(reinterpret_cast<char*>(size), sizeof size);
  in.read(reinterpret_cast<char*>(&map.scale), sizeof map.scale);
  if (!in || std::memcmp(magic, kMagic, sizeof magic) != 0 || size[0] <= 0 || size[1] <= 0 ||
      size[0] > 4 * kSignificanceMaxSide || size[1] > 4 * kSignificanceMaxSide)
    throw std::runtime_error("missing or damaged " + path);
  map.width = size[0], map.height = size[1];
  map.values.resize(std::size_t(map.width) * map.height);
  in.read(reinterpret_cast<char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  if (!in) throw std::runtime_error("truncated " + path);
  return map;
}

}  // namespace zoomwarp::warp
