// The cases of the methods' property tests: a sample image (samples/) with a saliency kind, every
// kind for each image, and gtest parameter names such as "boats_lake_sunset_gbvs".
#pragma once

#include <gtest/gtest.h>

#include <initializer_list>
#include <ostream>
#include <string>
#include <vector>

#include "warp/saliency/saliency.h"

namespace zoomwarp::testing {

struct SampleCase {
  const char* image;
  warp::Saliency kind;
  friend std::ostream& operator<<(std::ostream& out, const SampleCase& c) {
    return out << c.image << ", saliency=" << warp::saliency_name(c.kind);
  }
};

// Each image with every saliency kind.
inline std::vector<SampleCase> sample_cases(std::initializer_list<const char*> images) {
  std::vector<SampleCase> out;
  for (const char* image : images)
    for (warp::Saliency kind : warp::kSaliencies) out.push_back({image, kind});
  return out;
}

inline std::string sample_case_name(const ::testing::TestParamInfo<SampleCase>& info) {
  const std::string image = info.param.image;
  return image.substr(0, image.find('.')) + "_" + std::string(warp::saliency_name(info.param.kind));
}

}  // namespace zoomwarp::testing
