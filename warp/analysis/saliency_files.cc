#include "warp/analysis/saliency_files.h"

#include <cmath>
#include <sstream>

#include "warp/analysis/analysis_image.h"
#include "warp/analysis/derived_files.h"
#include "warp/saliency/gbvs.h"

namespace zoomwarp::warp {

namespace {

constexpr Magic kGbvsMagic = {'Z', 'W', 'G', 'B', 'V', 'S', '1', 0};

}  // namespace

// A map file (significance.bin, gbvs.bin): magic, width, height, scale, the values.
std::string saliency_map_bytes(const SignificanceMap& map, const Magic& magic) {
  std::ostringstream out;
  out.write(magic.data(), magic.size());
  put(out, std::int32_t(map.width));
  put(out, std::int32_t(map.height));
  put(out, map.scale);
  out.write(reinterpret_cast<const char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  return with_trailer(out.str());
}

SignificanceMap read_saliency_map_file(const tiles::ImageEntry& image, const char* file, const Magic& magic1, const Magic& magic2) {
  auto [bytes, format] = checked_payload(file, read_whole(image, file), magic1, magic2);
  ModelFileReader in(file, std::move(bytes));
  in.stream().seekg(std::streamoff(magic1.size()));
  SignificanceMap map;
  const auto w = in.get<std::int32_t>(), h = in.get<std::int32_t>();
  map.scale = in.get<double>();
  if (w <= 0 || h <= 0 || w > 4 * kSignificanceMaxSide || h > 4 * kSignificanceMaxSide || !(map.scale > 0))
    in.damaged("bad map size");
  // The map covers the image: its sides are the image's times the scale, give or take rounding.
  if (std::abs(w - map.scale * image.manifest.width) > 1 || std::abs(h - map.scale * image.manifest.height) > 2)
    in.damaged("made for another image size");
  if (in.remaining() < std::uint64_t(w) * std::uint64_t(h) * sizeof(float)) in.damaged("truncated");
  map.width = w, map.height = h;
  map.values.resize(std::size_t(w) * h);
  in.stream().read(reinterpret_cast<char*>(map.values.data()), std::streamsize(map.values.size() * sizeof(float)));
  if (format == 2 && in.remaining() != 0) in.damaged("trailing bytes");
  return map;
}


void write_gbvs_map(const std::string& dir, const SignificanceMap& map) {
  replace_file(dir, kGbvsFile, saliency_map_bytes(map, kGbvsMagic));
}

SignificanceMap read_gbvs_map(const tiles::ImageEntry& image) {
  return read_saliency_map_file(image, kGbvsFile, kGbvsMagic, kGbvsMagic);
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
    if (!damaged && add_derived_file(image, kGbvsFile, saliency_map_bytes(out.map, kGbvsMagic)))
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
