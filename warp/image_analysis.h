// The warp engine's files in an image version's folder, written at ingest and by curator edits,
// so that a view never touches full-resolution pixels and a server builds an image's operator
// without CGAL or the face detector:
//
//   significance.bin   the significance map (≤ 1024 px, floats), edits painted in
//   warp_model.bin     the coarsest mesh, the forest's kept nodes (as their split order) and
//                      every kept node's mean significance
//   warp.json          what the user gave: line constraints and significance edits, readable
//
// An edit never changes a published version: it publishes a new one (hard links to the same
// pyramid, new model files), conditional on the version it started from.
#pragma once

#include <optional>
#include <vector>

#include "tiles/pyramid_reader.h"
#include "tiles/store.h"
#include "warp/image_model.h"

namespace zoomwarp::warp {

inline constexpr const char* kSignificanceFile = "significance.bin";
inline constexpr const char* kModelFile = "warp_model.bin";
inline constexpr const char* kModelJsonFile = "warp.json";

// The pyramid level whose long side is at most kSignificanceMaxSide, read whole.
tiles::Raster read_reduced_image(const tiles::ImageEntry& image, tiles::PyramidReader& reader);

// The ingest hook: builds the image's model (no lines yet) and writes its files into the (still
// staged) folder. Throws std::runtime_error if it cannot write.
void write_image_analysis(const tiles::ImageEntry& image);

// Writes the model's files into `dir` (each to a temporary name, then renamed into place).
void write_image_model(const std::string& dir, const ImageModel& model);

// Reads them back; throws std::runtime_error if missing or damaged.
ImageModel read_image_model(const tiles::ImageEntry& image);
SignificanceMap read_significance(const tiles::ImageEntry& image);

struct ModelEdit {
  std::optional<std::vector<Segment>> lines;      // replaces all line constraints
  std::vector<SignificanceEdit> significance;     // painted in order
};

// Checks an edit: finite coordinates, lines longer than a pixel, polygons of ≥ 3 points,
// weights in [0, 1], at most 1000 lines / edits of 1000 points. Throws std::invalid_argument.
void validate(const ModelEdit& edit);

// Publishes a new version of `current`'s image with the edit applied to `model` (current's
// model; read from its files when not given). Throws std::invalid_argument for a bad edit and
// tiles::VersionConflict if the image changed since `current` was read.
std::shared_ptr<const tiles::ImageEntry> edit_image_model(tiles::Store& store, const tiles::ImageEntry& current,
                                                          const ModelEdit& edit, std::optional<ImageModel> model = {});

}  // namespace zoomwarp::warp
