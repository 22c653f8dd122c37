#include "api/deepzoom.h"

#include <algorithm>

namespace zoomwarp::api {

std::string dzi_descriptor(const tiles::Manifest& m, const DziLayout& layout, std::string_view format) {
  return "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
         "<Image xmlns=\"http://schemas.microsoft.com/deepzoom/2008\" Format=\"" +
         std::string(format) + "\" Overlap=\"" + std::to_string(layout.overlap) + "\" TileSize=\"" +
         std::to_string(layout.tile_size) + "\">\n  <Size Width=\"" + std::to_string(m.width) +
         "\" Height=\"" + std::to_string(m.height) + "\"/>\n</Image>\n";
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

}  // namespace zoomwarp::api
