// The last-resort fold guard every mesh method shares: a warp that folds some triangle is blended
// towards a fold-free one with the same boundary (the affine stretch, usually) as little as
// needed — the smallest t found by bisection for which (1 − t)·warp + t·fold_free folds nothing.
// Blending keeps the boundary on the target rectangle, since both warps have it there.
//
// Thread safety: pure functions.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/stop_token.h"

namespace zoomwarp::warp {

// Triangles of `mesh` whose signed area under `positions` is ≤ 0 (folded or degenerate).
std::vector<int> folded_triangles(const Mesh& mesh, const std::vector<Point>& positions);

// Replaces `positions` by the blend with the smallest t ∈ (0, 1] (20 bisection steps) that folds
// nothing — every triangle keeping at least a thousandth of its area under `fold_free`, so that
// none is left a sliver a rounding could turn over — and returns t; 0 (positions unchanged) if
// nothing folds. `fold_free` must fold nothing. Checks `stop` between steps (throws Stopped).
double blend_out_folds(const Mesh& mesh, std::vector<Point>& positions, const std::vector<Point>& fold_free,
                       const StopToken* stop = nullptr);

}  // namespace zoomwarp::warp
