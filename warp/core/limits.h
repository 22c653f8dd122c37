// Limits on everything a client controls in the warp engine: the screen of a view and the
// curator's edits. A view or an edit inside them has a bounded cost; api/ refuses anything
// outside them with a 4xx before any work is done (README "Limits", api/openapi.json).
#pragma once

namespace zoomwarp::warp::limits {

// The screen of a view (w, h): a side and the pixel count.
inline constexpr int kMaxScreenSide = 4096;
inline constexpr long long kMaxScreenPixels = 4096LL * 4096;

// Line constraints of one image: how many, and their summed length in units of the image's
// larger side (a line across the whole image is 1).
inline constexpr int kMaxLines = 64;
inline constexpr double kMaxTotalLineLength = 16;

// Significance edits: regions per PATCH, points per polygon, and regions kept with an image
// over all its edits (each edit adds to warp.json).
inline constexpr int kMaxRegionsPerEdit = 64;
inline constexpr int kMaxPolygonPoints = 256;
inline constexpr int kMaxStoredRegions = 1024;

}  // namespace zoomwarp::warp::limits
