// The automatically detected lines of an image version (lines/line_detection.h) and what becomes
// of them: suggestions to the curator, the `lines=auto` ICAZ model, MethodInput::detected_lines.
//
//   lines.detected.json   {"detector": "...", "lines": [[x0, y0, x1, y1], …]} in image pixels,
//                         longest first; written at ingest (write_image_analysis)
//
// Readable JSON rather than a binary model file: it is at most limits::kMaxLines segments (a few
// KB), the same shape GET /lines answers with, and worth reading by a person; damage shows as a
// parse or validation failure. It is derived data (a pure function of the version's pixels), so
// a version without it (ingested before detection existed), with a damaged one or with one from
// another detector gets the lines detected again in memory — never written into a published
// version. An edit's new version hard-links it (tiles::Store::make_staging_copy), so the
// suggestions survive edits unchanged.
//
// The curator's decisions are the user's data and live in warp.json: an accepted suggestion is
// simply one of the curator's lines; a dropped one is kept in `dismissed_lines`
// (ImageModel::dismissed_lines) and is not suggested again.
//
// Thread safety: free functions on immutable published folders; safe to call concurrently.
#pragma once

#include <string>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/core/mesh.h"
#include "warp/icaz/image_model.h"

namespace zoomwarp::warp {

inline constexpr const char* kDetectedLinesFile = "lines.detected.json";

// Detects the lines of `image` (its analysis image) and writes kDetectedLinesFile into its folder
// (ingest: the folder is still staged). Throws std::runtime_error if it cannot read or write.
void write_detected_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader);

// The version's detected lines: its file when intact and from this detector, else detected in
// memory. Throws std::runtime_error when the pyramid cannot be read.
std::vector<Segment> read_detected_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader);

// The suggestions left for the curator of the version whose model is `model`: the detected lines
// without those dismissed and those along the curator's lines (remaining_suggestions).
std::vector<Segment> suggested_lines(const tiles::ImageEntry& image, tiles::PyramidReader& reader,
                                     const ImageModel& model);

// The `lines=auto` line set [ICAZ §4.3 with Guo09 §3.3.3's detected lines]: the curator's lines,
// then each suggestion, longest first, cut back to its pieces at least d/4 from every line taken
// so far (clear_pieces; pieces shorter than d/2 dropped; d = sqrt(W·H/300)), as long as the count
// and total length stay within the curator's limits (limits.h). No suggestion then crosses or
// nearly touches another line, which is where CGAL's refinement fails or does not end
// (coarse_mesh.h). Should CGAL still refuse the set, the pieces are added one at a time and each
// one with which the coarsest mesh cannot be built is dropped; `dropped` (optional) counts them.
// The curator's lines are always kept, first and unchanged.
std::vector<Segment> auto_line_set(const ImageModel& model, const std::vector<Segment>& suggestions,
                                   int* dropped = nullptr);

}  // namespace zoomwarp::warp
