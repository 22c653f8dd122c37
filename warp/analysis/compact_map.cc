#include "warp/analysis/compact_map.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <vector>

#include "warp/analysis/deflated_payload.h"
#include "warp/analysis/model_file.h"

namespace zoomwarp::warp {

namespace {

static_assert(kSignificanceLevels == 65535, "two bytes per value");

struct Header {
  std::int32_t width, height;
  double scale;
};

// [LOCO-I §2.1]'s median edge detector: the left or the upper neighbour across an edge, else the
// plane through the three. On the first row the left neighbour, on the first column the upper.
int predicted(const std::uint16_t* q, int x, int y, int width) {
  const std::size_t at = std::size_t(y) * width + x;
  if (y == 0) return x == 0 ? 0 : q[at - 1];
  if (x == 0) return q[at - width];
  const int a = q[at - 1], b = q[at - width], c = q[at - width - 1];
  if (c >= std::max(a, b)) return std::min(a, b);
  if (c <= std::min(a, b)) return std::max(a, b);
  return a + b - c;
}

}  // namespace

// The residuals are written as two planes, every value's high byte, then every low byte: most
// high bytes are 0 or 255 (small residuals either way), which deflate codes in a few bits.
std::string compact_map_bytes(const SignificanceMap& map) {
  const std::size_t n = map.values.size();
  std::vector<std::uint16_t> q(n);
  for (std::size_t i = 0; i < n; ++i)
    q[i] = std::uint16_t(quantised_significance(map.values[i]) * kSignificanceLevels + 0.5f);
  std::string residuals(2 * n, '\0');
  for (int y = 0; y < map.height; ++y)
    for (int x = 0; x < map.width; ++x) {
      const std::size_t at = std::size_t(y) * map.width + x;
      const auto r = std::uint16_t(q[at] - predicted(q.data(), x, y, map.width));
      residuals[at] = char(r >> 8), residuals[n + at] = char(r & 0xff);
    }
  const Header h{map.width, map.height, map.scale};
  std::string out(sizeof h, '\0');
  std::memcpy(out.data(), &h, sizeof h);
  return out + deflated(residuals);
}

SignificanceMap parse_compact_map(const char* file, std::string_view bytes) {
  Header h;
  if (bytes.size() < sizeof h) throw ModelFileError(file, "truncated");
  std::memcpy(&h, bytes.data(), sizeof h);
  if (h.width <= 0 || h.height <= 0 || h.width > 4 * kSignificanceMaxSide || h.height > 4 * kSignificanceMaxSide ||
      !(h.scale > 0))
    throw ModelFileError(file, "bad map size");
  const std::size_t n = std::size_t(h.width) * std::size_t(h.height);
  const std::string residuals = inflated(file, bytes.substr(sizeof h), 2 * n);
  if (residuals.size() != 2 * n) throw ModelFileError(file, "the values are not the map's size");
  std::vector<std::uint16_t> q(n);
  SignificanceMap map;
  map.width = h.width, map.height = h.height, map.scale = h.scale;
  map.values.resize(n);
  for (int y = 0; y < h.height; ++y)
    for (int x = 0; x < h.width; ++x) {
      const std::size_t at = std::size_t(y) * h.width + x;
      const auto r = std::uint16_t(std::uint8_t(residuals[at]) << 8 | std::uint8_t(residuals[n + at]));
      q[at] = std::uint16_t(r + predicted(q.data(), x, y, h.width));
      map.values[at] = float(q[at]) / float(kSignificanceLevels);
    }
  return map;
}

}  // namespace zoomwarp::warp
