#include "tiles/icc_to_srgb.h"

#include <lcms2.h>

#include <cstdlib>
#include <stdexcept>
#include <string>
#include <utility>

namespace zoomwarp::tiles {

namespace {

std::string text_of(cmsHPROFILE profile, cmsInfoType info) {
  char text[256] = {};
  cmsGetProfileInfoASCII(profile, info, "en", "US", text, sizeof text);
  return text;
}

// Whether `profile` is sRGB under some name (the IEC 61966-2.1 profile most cameras and editors
// embed, or a copy of it): converting through it to sRGB moves no primary ramp or grey by more
// than one level. Converting sRGB to sRGB would only add rounding.
bool is_srgb(cmsHPROFILE profile) {
  cmsHPROFILE srgb = cmsCreate_sRGBProfile();
  cmsHTRANSFORM probe = cmsCreateTransform(profile, TYPE_RGB_8, srgb, TYPE_RGB_8, INTENT_RELATIVE_COLORIMETRIC, cmsFLAGS_NOCACHE);
  cmsCloseProfile(srgb);
  if (!probe) return false;
  bool same = true;
  for (int v = 0; v < 256 && same; v += 5) {
    const std::uint8_t in[4][3] = {{std::uint8_t(v), 0, 0}, {0, std::uint8_t(v), 0}, {0, 0, std::uint8_t(v)}, {std::uint8_t(v), std::uint8_t(v), std::uint8_t(v)}};
    std::uint8_t out[4][3];
    cmsDoTransform(probe, in, out, 4);
    for (int k = 0; k < 4; ++k)
      for (int c = 0; c < 3; ++c) same &= std::abs(int(out[k][c]) - int(in[k][c])) <= 1;
  }
  cmsDeleteTransform(probe);
  return same;
}

}  // namespace

std::unique_ptr<IccToSrgb> IccToSrgb::for_profile(const std::uint8_t* icc, std::size_t size, int channels) {
  if (icc == nullptr || size == 0 || channels < 3) return nullptr;
  cmsHPROFILE profile = cmsOpenProfileFromMem(icc, cmsUInt32Number(size));
  if (!profile) throw std::runtime_error("its embedded ICC profile cannot be read");
  if (cmsGetColorSpace(profile) != cmsSigRgbData) {
    cmsCloseProfile(profile);
    throw std::runtime_error("its embedded ICC profile is not an RGB profile (CMYK, Lab and grey profiles on "
                             "RGB pixels are not converted)");
  }
  if (is_srgb(profile)) {
    cmsCloseProfile(profile);
    return nullptr;
  }
  std::string description = text_of(profile, cmsInfoDescription);
  cmsHPROFILE srgb = cmsCreate_sRGBProfile();
  const cmsUInt32Number format = channels == 4 ? TYPE_RGBA_8 : TYPE_RGB_8;
  // Alpha is copied, not converted (cmsFLAGS_COPY_ALPHA); the transform keeps no cache, so
  // that concurrent converts share nothing that changes.
  cmsHTRANSFORM transform = cmsCreateTransform(profile, format, srgb, format, INTENT_RELATIVE_COLORIMETRIC,
                                               cmsFLAGS_BLACKPOINTCOMPENSATION | cmsFLAGS_COPY_ALPHA | cmsFLAGS_NOCACHE);
  cmsCloseProfile(srgb);
  cmsCloseProfile(profile);
  if (!transform) throw std::runtime_error("its embedded ICC profile cannot be converted to sRGB");
  return std::unique_ptr<IccToSrgb>(new IccToSrgb(transform, std::move(description)));
}

IccToSrgb::~IccToSrgb() { cmsDeleteTransform(static_cast<cmsHTRANSFORM>(transform_)); }

void IccToSrgb::convert(std::uint8_t* pixels, std::size_t count) const {
  cmsDoTransform(static_cast<cmsHTRANSFORM>(transform_), pixels, pixels, cmsUInt32Number(count));
}

}  // namespace zoomwarp::tiles
