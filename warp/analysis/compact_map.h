// The compact payload of the saliency maps' files (significance.bin and gbvs.bin, format 3;
// saliency_files.h): a map's values are multiples of 1 / kSignificanceLevels (saliency/precision.h), so
// each is a 16-bit q = round(65535 v); each is stored as its difference (mod 2^16) from the
// LOCO-I median predictor of its left, upper and upper-left neighbours [LOCO-I §2.1], and the
// differences — mostly near 0 on a smooth map — are deflated (deflated_payload.h) as two planes,
// the high bytes, then the low bytes.
//
//   int32 width, int32 height, double scale, deflated(width · height high bytes, then low bytes)
//
// Sizes: docs/ingest.md, "Compact analysis files (issue 28)".
//
// Thread safety: free functions; safe to call concurrently.
#pragma once

#include <string>
#include <string_view>

#include "warp/saliency/precision.h"

namespace zoomwarp::warp {

// `map`'s payload; values off the 1/65535 grid (a map read from a float file of format 1 or 2) are
// rounded to it.
std::string compact_map_bytes(const SignificanceMap& map);

// What compact_map_bytes wrote. Throws ModelFileError(file, …) for bytes that are not such a map
// or a map larger than 4 kSignificanceMaxSide on a side; the caller checks it against its image.
SignificanceMap parse_compact_map(const char* file, std::string_view bytes);

}  // namespace zoomwarp::warp
