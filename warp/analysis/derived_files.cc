#include "warp/analysis/derived_files.h"

#include "warp/analysis/detected_lines.h"
#include "warp/analysis/image_analysis.h"
#include "warp/analysis/method_files.h"
#include "warp/analysis/model_file.h"

namespace zoomwarp::warp {

bool add_derived_file(const tiles::ImageEntry& image, const char* file, const std::string& bytes) {
  try {
    image.files->write(file, bytes);
    return true;
  } catch (const std::exception&) {
    return false;
  }
}

std::vector<std::string> stored_analyses(const tiles::ImageEntry& image) {
  std::vector<std::string> out;
  const bool model = exists(image, kModelFile) && exists(image, kSignificanceFile) && exists(image, kModelJsonFile);
  if (model) out.push_back("icaz.default");
  if (model && exists(image, kGbvsFile)) out.push_back("icaz.gbvs");
  if (exists(image, kDetectedLinesFile)) out.push_back("lines");
  for (const RetargetingMethod* method : retargeting_methods())
    for (Saliency kind : kSaliencies)
      for (LineSet lines : kLineSets) {
        if (!method->precompute || (lines != LineSet::kAuto && !method->reads_lines) ||
            !exists(image, method_file_name(*method, kind, lines).c_str()))
          continue;
        std::string name = std::string(method->name) + "." + std::string(saliency_name(kind));
        if (lines != LineSet::kAuto) name += "." + std::string(line_set_name(lines));
        out.push_back(name);
      }
  return out;
}

}  // namespace zoomwarp::warp
