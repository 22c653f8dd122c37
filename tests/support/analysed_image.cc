#include "tests/support/analysed_image.h"

#include <algorithm>

#include "tests/support/images.h"
#include "tests/support/server_process.h"
#include "warp/lines/line_detection.h"
#include "warp/saliency/gbvs.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::testing {

AnalysedImage analyse_image(const tiles::Raster& image) {
  AnalysedImage a;
  a.model.width = image.width;
  a.model.height = image.height;
  const double f = std::min(1.0, double(warp::kSignificanceMaxSide) / std::max(image.width, image.height));
  a.analysis = resize(image, std::max(1, int(image.width * f)), std::max(1, int(image.height * f)));
  a.detected = warp::detect_lines(a.analysis, image.width, image.height);
  return a;
}

AnalysedImage analyse_sample(const std::string& file) { return analyse_image(load_image(samples_dir() + "/" + file)); }

warp::SignificanceMap AnalysedImage::saliency(warp::Saliency kind) const {
  if (kind == warp::Saliency::kGbvs)
    return warp::compute_gbvs(analysis, int(model.width), analysis.width, analysis.height);
  warp::SignificanceOptions no_faces;
  no_faces.face_cascade = "";
  return warp::compute_significance(analysis, int(model.width), no_faces);
}

warp::MethodInput AnalysedImage::input(warp::Saliency kind, const warp::SignificanceMap& map) const {
  return {model, kind, map, analysis, model.lines, detected};
}

}  // namespace zoomwarp::testing
