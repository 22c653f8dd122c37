// A view as every retargeting method answers it: the request (zoom, view centre, screen) and the
// result — a source mesh with its positions in the warped image and on the screen — which
// render/render.h texture-maps and api/mesh_json.h sends to clients. ICAZ fills every field;
// the other methods (methods/) leave the forest fields empty.
#pragma once

#include <vector>

#include "warp/core/mesh.h"
#include "warp/core/stop_token.h"
#include "warp/core/warp_result.h"
#include "warp/core/zoom_curve.h"

namespace zoomwarp::warp {

struct ViewRequest {
  double zoom = 0;
  double cx = 0, cy = 0;  // view centre, image pixels
  int screen_width = 480, screen_height = 360;
  ZoomCurve curve = ZoomCurve::kGeometric;
  ZoomFrame frame;  // what zoom 0 shows; the default is the paper's global view (fit=warp)
  double max_screen_area = 500;  // px², the paper's runtime threshold [ICAZ §6.1]
  // The request's deadline and cancel flag, checked between steps (Stopped is thrown); none: runs
  // to the end. Not owned.
  const StopToken* stop = nullptr;
};

struct View {
  ZoomGeometry geometry;
  double view_x = 0, view_y = 0;   // top-left of the viewing area in warped pixels
  bool centre_clamped = false;     // the viewing area had to move to stay inside the image
  // Traditional zoom: screen = (source − (view_x, view_y)) · geometry.screen_scale for every point
  // of the image, so the renderer may resample the whole screen with one affine warp.
  bool uniform = false;
  Mesh source;                     // the refined mesh, image pixels
  std::vector<Point> warped;       // per vertex, warped-image pixels
  std::vector<Point> screen;       // per vertex, screen pixels
  std::vector<int> forest_vertex;  // per vertex, its forest vertex (stable across views)
  std::vector<int> nodes;          // per triangle, its forest node (the LOD cut)
  std::vector<int> visible;        // triangles that touch the screen
  WarpResult coarse_stats, fine_stats;
  int forest_epoch = 0;            // forest_vertex and nodes are valid while the epoch holds
};

// Geomorphing [ICAZ §5.3]: the common refinement of two views' LOD cuts, with both views' screen
// positions on it, so a client can interpolate from one to the other without popping.
struct Geomorph {
  Mesh source;                     // image pixels
  std::vector<int> forest_vertex;
  std::vector<Point> from, to;     // per vertex, screen positions in the first and second view
};

}  // namespace zoomwarp::warp
