#include "warp/compare/contact_sheet.h"

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace zoomwarp::warp {

namespace {

constexpr int kGap = 8, kLabel = 48, kLineHeight = 15;
constexpr std::uint8_t kBackground = 48;

// The RGB of one pixel of `r`, alpha composited over black.
void rgb_of(const tiles::Raster& r, int x, int y, std::uint8_t out[3]) {
  const std::uint8_t* p = r.row(y) + std::size_t(x) * r.channels;
  const bool grey = r.channels <= 2;
  const int alpha = r.channels == 2 || r.channels == 4 ? p[r.channels - 1] : 255;
  for (int c = 0; c < 3; ++c) out[c] = std::uint8_t((grey ? p[0] : p[c]) * alpha / 255);
}

}  // namespace

tiles::Raster contact_sheet(const std::vector<std::vector<SheetCell>>& rows) {
  if (rows.empty() || rows[0].empty()) throw std::invalid_argument("a contact sheet needs cells");
  const int w = rows[0][0].screen.width, h = rows[0][0].screen.height;
  std::size_t columns = 0;
  for (const auto& row : rows) {
    columns = std::max(columns, row.size());
    for (const SheetCell& cell : row)
      if (cell.screen.width != w || cell.screen.height != h || cell.screen.channels < 1 || cell.screen.channels > 4)
        throw std::invalid_argument("contact sheet cells must all have the same size");
  }
  tiles::Raster sheet(kGap + int(columns) * (w + kGap), kGap + int(rows.size()) * (h + kLabel + kGap), 3);
  std::fill(sheet.pixels.begin(), sheet.pixels.end(), kBackground);
  cv::Mat canvas(sheet.height, sheet.width, CV_8UC3, sheet.pixels.data());
  for (std::size_t r = 0; r < rows.size(); ++r)
    for (std::size_t c = 0; c < rows[r].size(); ++c) {
      const SheetCell& cell = rows[r][c];
      const int x0 = kGap + int(c) * (w + kGap), y0 = kGap + int(r) * (h + kLabel + kGap);
      for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) rgb_of(cell.screen, x, y, sheet.row(y0 + y) + std::size_t(x0 + x) * 3);
      for (std::size_t i = 0; i < cell.label.size() && i < 3; ++i)
        cv::putText(canvas, cell.label[i], cv::Point(x0 + 2, y0 + h + 13 + int(i) * kLineHeight), cv::FONT_HERSHEY_SIMPLEX,
                    0.42, cv::Scalar(235, 235, 235), 1, cv::LINE_AA);
    }
  return sheet;
}

}  // namespace zoomwarp::warp
