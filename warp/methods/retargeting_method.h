// The retargeting methods a request may name (`method=`), as a registry of plain descriptions.
// ICAZ and traditional zoom are not in it: they are the icaz/ operator's own (methods/icaz_retargeter.h);
// every other method is one entry here, with the precompute/solve split of libigl's
// arap_precomputation/arap_solve:
//
//   precompute  per image version and saliency kind, everything that does not depend on the
//               target size — stored as the model file "<name>.<saliency>.bin" beside the
//               version's other model files (analysis/method_files.h), written at ingest and by
//               edits whose inputs changed;
//   load        the Retargeter of that version from it; each request then retargets the whole
//               image to the screen's aspect (cached per target size) and zooms traditionally.
//
// Thread safety: the registry is immutable; precompute and load may run concurrently.
#pragma once

#include <array>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "tiles/raster.h"
#include "warp/core/mesh.h"
#include "warp/icaz/image_model.h"
#include "warp/methods/retargeter.h"
#include "warp/saliency/saliency.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

// What a precomputation may read, all of one image version. The lines to keep straight are
// `lines` then `detected_lines` (the request's line set, analysis/line_set.h: both for lines=auto,
// the first for lines=curator, neither for lines=none) — not model.lines.
struct MethodInput {
  const ImageModel& model;            // image size, default significance
  Saliency saliency_kind;
  const SignificanceMap& saliency;    // the selected kind, faces and curator edits painted in
  const tiles::Raster& analysis_image;  // the reduced copy the maps were made from (long side
                                        // ≤ kSignificanceMaxSide, `saliency.scale` px per image px)
  const std::vector<Segment>& lines;  // the curator's lines, image pixels (empty for lines=none)
  // Automatic lines (lines/), image pixels, longest first: the version's suggestions the curator
  // neither dismissed nor drew (analysis/detected_lines.h suggested_lines); empty unless lines=auto.
  const std::vector<Segment>& detected_lines;
};

struct RetargetingMethod {
  std::string_view name;     // the `method=` value, e.g. "seam"
  std::string_view summary;  // one sentence for the viewer and the OpenAPI description
  std::string_view zoom;     // what `zoom` means for it (README, OpenAPI)
  bool has_mesh = true;      // false: /mesh answers 501 (seam carving)
  // What the method does with the request's line set (analysis/line_set.h), for /v1/methods and
  // the OpenAPI description; empty: it takes no lines, and every `lines=` gives the same view.
  std::string_view lines;
  // The model file's magic (8 bytes, its format version included); unused without precompute.
  std::array<char, 8> magic{};
  // Whether the precomputation reads lines (MethodInput::lines and detected_lines): it is then
  // kept per line set, and an edit of the lines or of the dismissed suggestions precomputes it
  // again. Every precomputation is taken to read the saliency map (edited by significance edits).
  bool reads_lines = false;
  // Whether load() reads the lines, as the ImageModel's `lines` of the request's line set (the
  // ICAZ model of that set, analysis/image_analysis.h ModelVariant: for lines=auto the detected
  // lines as ICAZ meshes them). Such a method takes no lines in its precomputation.
  bool loads_lines = false;
  // The precomputation's bytes; empty: the method keeps no file and load() gets "".
  std::function<std::string(const MethodInput&)> precompute;
  // The precomputation's peak memory per analysis-image pixel, measured (issue 18: RSS sampled
  // every 20 ms through each job of a 996×934 analysis image, glibc's mmap threshold at 64 KiB so
  // that RSS follows the live heap). Ingest runs precomputations side by side only while these
  // estimates fit its budget (warp/analysis/image_analysis.cc).
  std::size_t precompute_bytes_per_pixel = 0;
  // The Retargeter of one version from the model, the selected saliency map and the
  // precomputation's bytes. Throws std::runtime_error for bytes it cannot parse.
  std::function<std::unique_ptr<Retargeter>(const ImageModel&, const SignificanceMap& saliency,
                                            std::string_view precomputed)>
      load;
};

// `zoom` of the methods that retarget the whole image once to the screen's aspect ratio and then
// zoom into the result uniformly (mp, patch, polyfem, retarget-zoom).
inline constexpr std::string_view kZoomIntoTheRetargetedImage =
    "0 shows the whole retargeted image, 1 shows it 1:1 (the plain crop when the screen has the image's aspect "
    "ratio); the view centre is tracked through the warp";

// Every registered method, in the order the viewer and `zoomwarp compare --methods all` list them.
std::span<const RetargetingMethod* const> retargeting_methods();

// The method called `name`, or nullptr.
const RetargetingMethod* find_retargeting_method(std::string_view name);

}  // namespace zoomwarp::warp
