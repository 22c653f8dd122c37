#include "api/deepzoom.h"

#include <algorithm>
#include <cmath>

#include "api/url.h"

namespace zoomwarp::api {

std::string dzi_descriptor(const tiles::Manifest& m, const DziLayout& layout, std::string_view format) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<Image xmlns=\"http://schemas.microsoft.com/deepzoom/2008\" Format=\"" +
         std::string(format) + "\" Overlap=\"" + std::to_string(layout.overlap) + "\" TileSize=\"" +
         std::to_string(layout.tile_size) + "\">\n  <Size Width=\"" + std::to_string(m.width) +
         "\" Height=\"" + std::to_string(m.height) + "\"/>\n</Image>\n";
}

std::optional<DziTileName> parse_dzi_tile_name(std::string_view name) {
  const std::size_t underscore = name.find('_'), dot = name.rfind('.');
  if (underscore == std::string_view::npos || dot == std::string_view::npos || dot < underscore) return std::nullopt;
  auto col = parse_small_uint(name.substr(0, underscore));
  auto row = parse_small_uint(name.substr(underscore + 1, dot - underscore - 1));
  if (!col || !row) return std::nullopt;
  return DziTileName{*col, *row, std::string(name.substr(dot + 1))};
}

std::optional<DziTile> dzi_tile(const tiles::Manifest& m, const DziLayout& layout, int level,
                                int col, int row) {
  if (level < 0 || level >= m.levels || col < 0 || row < 0) return std::nullopt;
  const int k = m.levels - 1 - level;
  const long long lw = m.level_width(k), lh = m.level_height(k), ts = layout.tile_size;
  const long long x = (long long)col * ts, y = (long long)row * ts;
  if (x >= lw || y >= lh) return std::nullopt;
  const long long x0 = std::max(0LL, x - layout.overlap), y0 = std::max(0LL, y - layout.overlap);
  const long long x1 = std::min(lw, x + ts + layout.overlap), y1 = std::min(lh, y + ts + layout.overlap);
  return DziTile{k, tiles::Rect{x0, y0, x1 - x0, y1 - y0}};
}

int dzi_level_for(const tiles::Manifest& m, double magnification) {
  const int full = m.levels - 1;
  if (!(magnification > 0)) return 0;
  // Stored level k = floor(log2(1 / magnification)) has 2^-k ≥ magnification; DZI counts upwards.
  const int k = std::clamp(int(std::floor(std::log2(1 / magnification) + 1e-9)), 0, full);
  return full - k;
}

std::vector<DziTileRef> dzi_tiles_covering(const tiles::Manifest& m, const DziLayout& layout, int level, double u0,
                                           double v0, double u1, double v1) {
  std::vector<DziTileRef> out;
  if (level < 0 || level >= m.levels) return out;
  const int k = m.levels - 1 - level;
  const double scale = double(m.level_width(k)) / m.width;
  const long long lw = m.level_width(k), lh = m.level_height(k), ts = layout.tile_size;
  auto index = [&](double v, long long size) {
    return std::clamp<long long>((long long)std::floor(v * scale) / ts, 0, (size - 1) / ts);
  };
  const long long c0 = index(std::max(0.0, u0), lw), c1 = index(std::min<double>(m.width, u1), lw);
  const long long r0 = index(std::max(0.0, v0), lh), r1 = index(std::min<double>(m.height, v1), lh);
  for (long long r = r0; r <= r1; ++r)
    for (long long c = c0; c <= c1; ++c) out.push_back({level, int(c), int(r)});
  return out;
}

}  // namespace zoomwarp::api
