// View paths, the input of `zoomwarp replay` (format and shipped paths: tests/load/README.md).
// JSON lines, one viewer action per line:
//
//   {"action": "zoom" | "pan", "zoom": z, "cx": x, "cy": y, "w": W, "h": H}
//
// z in [0, 1]; cx, cy the view centre in full-resolution image pixels; w, h the screen, 16…4096,
// optional (480×360). Blank lines and lines starting with # are skipped.
#pragma once

#include <string>
#include <string_view>
#include <vector>

namespace zoomwarp::server {

struct ViewAction {
  enum class Kind { kZoom, kPan };
  Kind kind = Kind::kZoom;
  double zoom = 0, cx = 0, cy = 0;
  int width = 480, height = 360;
  std::string where;  // "file:line", so later checks (e.g. against the image size) can point at it
};

std::string_view kind_name(ViewAction::Kind kind);

// Reads a whole view-path file. Parsing is strict, like the server's: an unknown key, a missing
// one, a number out of range is an error. Throws std::invalid_argument "file:line: what is wrong",
// or naming the file when it cannot be read or holds no action.
std::vector<ViewAction> read_view_path(const std::string& file);

}  // namespace zoomwarp::server
