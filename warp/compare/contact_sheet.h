// The contact sheet of `zoomwarp compare` (docs/compare.md): the screens of several methods side by
// side — a row per method, a column per zoom — each with a label of up to three lines drawn
// under it (OpenCV's Hershey font, so the sheet is the same on every machine).
//
// Plain function on plain data; thread-safe.
#pragma once

#include <string>
#include <vector>

#include "tiles/raster.h"

namespace zoomwarp::warp {

struct SheetCell {
  tiles::Raster screen;             // any channel count (1–4); alpha is composited over black
  std::vector<std::string> label;   // lines, ASCII
};

// Every cell is w × h (the first cell's size; std::invalid_argument otherwise, or when there are
// no cells). The sheet is RGB: a dark grey background, 8 px gaps, 48 px of label under each cell.
tiles::Raster contact_sheet(const std::vector<std::vector<SheetCell>>& rows);

}  // namespace zoomwarp::warp
