// The JSON bodies of curator edits (api/openapi.json, "Lines" and "SignificanceEdit"), parsed
// strictly: exactly the documented members, finite numbers inside the image (W × H), polygons of
// at least 3 points, weights in [0, 1], rectangles of positive size. Anything else is an
// ApiError(400, "invalid_body") saying what was wrong. Over a limit of warp/core/limits.h — lines and
// their total length, regions per edit, points per polygon — it is an ApiError(413) whose code
// names the limit: too_many_lines, lines_too_long, too_many_regions, too_many_points. (Regions
// kept over all edits are checked when the edit is applied: warp::edit_image_model.)
#pragma once

#include <string_view>

#include "warp/analysis/image_analysis.h"

namespace zoomwarp::api {

// {"lines": [[x0, y0, x1, y1], …], "dismissed": [[x0, y0, x1, y1], …]}: "lines" replaces the
// curator's lines; "dismissed" (optional; absent leaves them as they are) replaces the suggested
// lines the curator dropped, at most limits::kMaxLines of them (413 too_many_lines).
warp::ModelEdit parse_lines_body(std::string_view body, double W, double H);

// {"regions": [{"rect": [x, y, w, h], "weight": s} | {"polygon": [[x, y], …], "weight": s}, …]}
warp::ModelEdit parse_significance_body(std::string_view body, double W, double H);

}  // namespace zoomwarp::api
