// Significance [ICAZ §4, after Wang08]: how much each part of the image matters,
// so that the warp distorts it less. Computed once per image at reduced resolution:
//
//   significance = gradient norm × spectral-residual saliency, raised to 1 on detected faces,
//
// then averaged per triangle and normalised to [w_min, 1]. Spectral residual (Hou & Zhang 2007)
// was chosen over an Itti-style model: it needs one 64×64 FFT, no training and no parameters to
// tune, and its blobs mark "things standing out" where the gradient marks edges, so the product
// keeps edges of salient things and fades texture in flat-saliency areas (sky, water, grass).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "tiles/raster.h"
#include "warp/core/mesh.h"

namespace zoomwarp::warp {

// Values in [0, 1] over the whole image, at `scale` map pixels per image pixel.
struct SignificanceMap {
  int width = 0, height = 0;
  double scale = 1;
  std::vector<float> values;  // row-major

  float at(int x, int y) const { return values[std::size_t(y) * width + x]; }
};

// Largest side of the map: significance is a low-frequency signal, 1024 px is plenty.
inline constexpr int kSignificanceMaxSide = 1024;

// Where Debian's opencv-data installs the Haar cascade for frontal faces.
inline constexpr const char* kDefaultFaceCascade = "/usr/share/opencv4/haarcascades/haarcascade_frontalface_default.xml";

struct SignificanceOptions {
  // Haar cascade for frontal faces; empty or missing: no face boost (find_face_cascade says why).
  std::string face_cascade = kDefaultFaceCascade;
  // The faces of the image being analysed when they are already known (map pixels, as
  // detect_faces finds them): ingest's analysis finds them once for every saliency kind, each
  // detection costing as much as the rest of a map. Unset: found with face_cascade.
  std::optional<std::vector<tiles::Rect>> faces;
};

// The face detector's cascade as found at start-up.
struct FaceCascade {
  std::string path;     // the file that loads; empty when face detection is off
  std::string problem;  // why it is off: "cascade file not found" or "cascade file does not load"
};

// Finds the cascade: `configured` if it exists; if `configured` is the default and missing, the
// same file in OpenCV's other data folders (/usr/local/share/opencv4, /usr/share/opencv, and
// where OPENCV_SAMPLES_DATA_PATH points). The file found must load as a cascade.
FaceCascade find_face_cascade(const std::string& configured);

// `image` is the whole image at reduced resolution (e.g. a pyramid level), RGB or RGBA;
// `image_width` is the full-resolution width it stands for (sets `scale`).
SignificanceMap compute_significance(const tiles::Raster& image, int image_width,
                                     const SignificanceOptions& options = {});

// Faces found (in map pixels) by the Haar cascade: exposed for tests and for the viewer.
std::vector<tiles::Rect> detect_faces(const tiles::Raster& image, const std::string& cascade);

// options.faces when set, else detect_faces(image, options.face_cascade).
std::vector<tiles::Rect> faces_of(const tiles::Raster& image, const SignificanceOptions& options);

// Sets each face box (map pixels, as detect_faces finds them in the image the map was made
// from), enlarged by a fifth on each side, fully significant: every saliency kind gets it.
void paint_faces(SignificanceMap& map, const std::vector<tiles::Rect>& faces);

// A curator's edit: the significance inside `polygon` (image pixels) becomes `weight` ∈ [0, 1].
struct SignificanceEdit {
  std::vector<Point> polygon;
  float weight = 1;
};

// Sets the significance inside a polygon (image pixels) to `weight` (curator edits).
void paint_polygon(SignificanceMap& map, const std::vector<Point>& polygon, float weight);

// Mean of the map over a triangle given in image pixels (the value at its centroid when it
// covers no map pixel centre).
double mean_over_triangle(const SignificanceMap& map, const Point& a, const Point& b, const Point& c);

// Mean significance of every triangle of `mesh` (image pixels), normalised to [w_min, 1]: the
// per-triangle weights w_f of the shape energy.
std::vector<double> triangle_weights(const Mesh& mesh, const SignificanceMap& map, double w_min);

}  // namespace zoomwarp::warp
