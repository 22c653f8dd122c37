#include "warp/analysis/saliency_files.h"

#include <cstdint>

#include "warp/analysis/analysis_image.h"
#include "warp/analysis/compact_map.h"
#include "warp/analysis/derived_files.h"
#include "warp/saliency/gbvs.h"
#include "warp/saliency/precision.h"

namespace zoomwarp::warp {

namespace {

constexpr SaliencyFileMagics kGbvsMagics = {{'Z', 'W', 'G', 'B', 'V', 'S', '1', 0},
                                             {'Z', 'W', 'G', 'B', 'V', 'S', '1', 0},
                                             {'Z', 'W', 'G', 'B', 'V', 'S', '2', 0}};

// Formats 1 and 2's payload: width, height, scale, a float per value.
SignificanceMap float_map(const char* file, std::string bytes, int format) {
  ModelFileReader in(file, std::move(bytes));
  SignificanceMap map;
  const auto w = in.get<std::int32_t>(), h = in.get<std::int32_t>();
  map.scale = in.get<double>();
  if (w <= 0 || h <= 0 || w > 4 * kSignificanceMaxSide || h > 4 * kSignificanceMaxSide || !(map.scale > 0))
    in.damaged("bad map size");
  if (in.remaining() < std::uint64_t(w) * std::uint64_t(h) * sizeof(float)) in.damaged("truncated");
  map.width = w, map.height = h;
  map.values.resize(std::size_t(w) * h);
  in.stream().read(reinterpret_cast<char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  if (format == 2 && in.remaining() != 0) in.damaged("trailing bytes");
  // At the precision every map has now, so that this version's maps agree with those rebuilt in
  // memory (saliency/precision.h).
  quantise(map);
  return map;
}

}  // namespace

std::string saliency_map_bytes(const SignificanceMap& map, const SaliencyFileMagics& magics) {
  return with_trailer(std::string(magics.compact.begin(), magics.compact.end()) + compact_map_bytes(map));
}

SignificanceMap read_saliency_map_file(const tiles::ImageEntry& image, const char* file,
                                       const SaliencyFileMagics& magics) {
  std::string bytes = read_whole(image, file);
  SignificanceMap map;
  if (bytes.compare(0, magics.compact.size(), magics.compact.data(), magics.compact.size()) == 0) {
    const std::string payload = checked_payload(file, std::move(bytes), magics.compact, magics.compact).first;
    map = parse_compact_map(file, std::string_view(payload).substr(magics.compact.size()));
  } else {
    auto [payload, format] = checked_payload(file, std::move(bytes), magics.floats_untrailed, magics.floats);
    map = float_map(file, payload.substr(magics.floats.size()), format);
  }
  // Made from this image's analysis image, so of its size. (Not the sides times `scale`, give or
  // take rounding: scale is width over width, and a 2×10000 image's 1×1024 map has 0.5 for 0.1024.)
  const int level = analysis_level(image.manifest);
  if (map.width != image.manifest.level_width(level) || map.height != image.manifest.level_height(level))
    throw ModelFileError(file, "made for another image size");
  return map;
}

void write_gbvs_map(const tiles::VersionFiles& files, const SignificanceMap& map) {
  files.write(kGbvsFile, saliency_map_bytes(map, kGbvsMagics));
}

SignificanceMap read_gbvs_map(const tiles::ImageEntry& image) {
  return read_saliency_map_file(image, kGbvsFile, kGbvsMagics);
}

LoadedSaliency load_saliency_map(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 Saliency kind, const SignificanceOptions& significance) {
  if (kind == Saliency::kDefault) return {model.significance, ""};
  LoadedSaliency out;
  try {
    out.map = read_gbvs_map(image);
  } catch (const ModelFileError& e) {
    const bool damaged = exists(image, kGbvsFile);
    if (damaged) out.damaged = e.what();
    out.map = gbvs_significance(read_reduced_image(image, reader), image.manifest.width, significance);
    // Never computed for this version (issue 28: on first use): kept with it, and read back as
    // every later load reads it.
    if (!damaged && add_derived_file(image, kGbvsFile, saliency_map_bytes(out.map, kGbvsMagics)))
      out.map = read_gbvs_map(image);
  }
  // The curator's regions apply to every kind of map, painted in the order they were made.
  for (const SignificanceEdit& edit : model.edits) paint_polygon(out.map, edit.polygon, edit.weight);
  return out;
}

SignificanceMap saliency_map(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                             Saliency kind, const SignificanceOptions& significance) {
  return load_saliency_map(image, reader, model, kind, significance).map;
}

}  // namespace zoomwarp::warp
