// An image as ingest analyses it for the retargeting methods (warp/methods/retargeting_method.h
// MethodInput): its reduced copy (long side ≤ kSignificanceMaxSide), the lines detected in it,
// and a saliency map of either kind made from that copy. No face boost (no cascade: a model does
// not depend on opencv-data being installed) and no curator edits or lines.
//
// Thread safety: plain data; const use from several threads is safe.
#pragma once

#include <string>
#include <vector>

#include "tiles/raster.h"
#include "warp/icaz/image_model.h"
#include "warp/methods/retargeting_method.h"
#include "warp/saliency/saliency.h"

namespace zoomwarp::testing {

struct AnalysedImage {
  warp::ImageModel model;  // the image's size only
  tiles::Raster analysis;  // the reduced copy, OpenImageIO's resize of the whole image
  std::vector<warp::Segment> detected;  // detect_lines on `analysis`, image px

  // compute_significance or compute_gbvs of `analysis`, at its size.
  warp::SignificanceMap saliency(warp::Saliency kind) const;
  // The precomputation's input; refers to this and to `map`, which must outlive it.
  warp::MethodInput input(warp::Saliency kind, const warp::SignificanceMap& map) const;
};

AnalysedImage analyse_image(const tiles::Raster& image);

// analyse_image of samples/<file>.
AnalysedImage analyse_sample(const std::string& file);

}  // namespace zoomwarp::testing
