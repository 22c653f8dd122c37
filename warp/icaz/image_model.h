// What the warp engine knows about one image version [ICAZ §4–5.3], built at ingest and kept
// with the image (model_io.h): the significance map, the user's line constraints, the coarsest
// mesh built with them, the multi-resolution forest down to the triangles a view asks for at
// 100 %, and every forest node's mean significance. Curator edits — new lines, a region marked
// more or less important — update it in place of a re-ingest.
//
// Not thread-safe: plain data. Shared read-only (Icaz keeps its own const copy), it may be read
// from several threads; set_lines and add_significance_edit need it to themselves.
#pragma once

#include <vector>

#include "tiles/raster.h"
#include "warp/meshing/coarse_mesh.h"
#include "warp/icaz/forest.h"
#include "warp/saliency/significance.h"

namespace zoomwarp::warp {

struct ForestOptions {
  // Leaves are split down to this area (source px²): the default runtime threshold (500 px² on
  // screen) at 100 %, where a source pixel is a screen pixel.
  double min_area = 500;
  // At most this many nodes are built and stored (≈ 6 bytes each on disk, ≈ 60 in memory); a
  // 20 MP photo needs ~80 000, a 300 MP image would need 1.2 M and keeps its last levels lazy.
  int max_nodes = 1 << 18;
};

struct ImageModel {
  double width = 0, height = 0;
  std::vector<Segment> lines;          // line constraints, image pixels; the coarsest mesh follows them
  // The lines the warp keeps straight, each whole [ICAZ §4.3]: `lines`, but for the lines=auto
  // variant (image_analysis.h) the curator's and every whole detected line, of which the mesh
  // follows only the pieces CGAL can mesh (auto_line_set) — the rest of a line is held through the
  // triangles it crosses (shape_warp.h; issue 30).
  std::vector<Segment> straight_lines;
  SignificanceMap significance;        // with `edits` painted in
  std::vector<SignificanceEdit> edits;  // in the order they were made
  // Automatically detected lines (lines/) the curator dropped: kept in warp.json so that they are
  // not suggested again; the warp does not use them.
  std::vector<Segment> dismissed_lines;
  CoarseMesh coarse;                   // built with `lines`
  Forest forest;                       // over coarse.mesh; its kept nodes were built here
  std::vector<float> node_mean;        // per kept forest node, its mean significance
  double w_min = 0.2;  // weight floor (docs/algorithms.md, ICAZ: 0.2 avoided fold-overs where 0.05 did not)
};

// Builds the model from a reduced-resolution copy of the image (≤ kSignificanceMaxSide).
ImageModel make_image_model(const tiles::Raster& reduced, double width, double height,
                            const std::vector<Segment>& lines = {}, const CoarseMeshOptions& mesh = {},
                            const ForestOptions& forest = {}, const SignificanceOptions& significance = {});

// Replaces the line constraints (and straight_lines by them): the coarsest mesh, the forest and
// the node means are rebuilt.
void set_lines(ImageModel& model, const std::vector<Segment>& lines, const CoarseMeshOptions& mesh = {},
               const ForestOptions& forest = {});

// Replaces the significance map by another of the same image (another saliency kind, the
// curator's edits already painted in) and recomputes every kept node's mean from it; the mesh
// and the forest stay.
void set_significance(ImageModel& model, SignificanceMap map);

// Paints regions into the significance map, in order, and updates the means of the nodes they
// touch (each such node once).
void add_significance_edits(ImageModel& model, const std::vector<SignificanceEdit>& edits);

}  // namespace zoomwarp::warp
