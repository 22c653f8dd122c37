#include "warp/analysis/method_files.h"

#include <chrono>
#include <stdexcept>

#include "warp/analysis/analysis_image.h"
#include "warp/analysis/detected_lines.h"
#include "warp/analysis/model_file.h"

namespace zoomwarp::warp {

namespace {

// The precomputation of `method` from the version's pixels (the reduced copy every map is made from).
std::string precompute(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                       const RetargetingMethod& method, Saliency kind) {
  const tiles::Raster analysis = read_reduced_image(image, reader);
  const SignificanceMap saliency = saliency_map(image, reader, model, kind);
  const std::vector<Segment> detected = suggested_lines(image, reader, model);
  return method.precompute(MethodInput{model, kind, saliency, analysis, detected});
}

std::string sealed(const RetargetingMethod& method, const std::string& payload) {
  return with_trailer(std::string(method.magic.begin(), method.magic.end()) + payload);
}

}  // namespace

std::string method_file_name(const RetargetingMethod& method, Saliency saliency) {
  return std::string(method.name) + "." + std::string(saliency_name(saliency)) + ".bin";
}

std::vector<MethodFileTiming> write_method_files(const std::string& dir, const tiles::ImageEntry& image,
                                                 tiles::PyramidReader& reader, const ImageModel& model,
                                                 std::span<const Saliency> kinds, MethodSelection which) {
  std::vector<MethodFileTiming> out;
  for (const RetargetingMethod* method : retargeting_methods()) {
    if (!method->precompute || (which == MethodSelection::kReadingLines && !method->reads_lines)) continue;
    for (Saliency kind : kinds) {
      const auto start = std::chrono::steady_clock::now();
      const std::string file = method_file_name(*method, kind);
      replace_file(dir, file, sealed(*method, precompute(image, reader, model, *method, kind)));
      out.push_back({file, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count()});
    }
  }
  return out;
}

LoadedRetargeter load_retargeter(const tiles::ImageEntry& image, tiles::PyramidReader& reader, const ImageModel& model,
                                 const RetargetingMethod& method, Saliency saliency) {
  const SignificanceMap map = saliency_map(image, reader, model, saliency);
  if (!method.precompute) return {method.load(model, map, ""), MethodSource::kNoFile, ""};
  const std::string file = method_file_name(method, saliency);
  if (!exists(image, file.c_str()))
    return {method.load(model, map, precompute(image, reader, model, method, saliency)), MethodSource::kBuiltInMemory, ""};
  try {
    // The same magic twice: these files have always had the trailer.
    auto [payload, format] = checked_payload(file.c_str(), read_whole(image, file.c_str()), method.magic, method.magic);
    try {
      return {method.load(model, map, std::string_view(payload).substr(method.magic.size())), MethodSource::kStored, ""};
    } catch (const std::runtime_error& e) {
      throw ModelFileError(file, e.what());
    }
  } catch (const ModelFileError& damaged) {
    return {method.load(model, map, precompute(image, reader, model, method, saliency)), MethodSource::kRebuiltDamaged,
            damaged.what()};
  }
}

}  // namespace zoomwarp::warp
