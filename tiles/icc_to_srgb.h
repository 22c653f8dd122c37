// A source's embedded ICC profile applied at ingest: its 8-bit RGB(A) pixels converted to sRGB
// (LittleCMS 2, relative colorimetric intent with black point compensation), because every
// pyramid zoomwarp serves, every tile and every rendered view, is sRGB — IIIF and Deep Zoom
// clients, the web viewer and browsers take untagged tiles as sRGB. Without it a photograph kept
// in Adobe RGB or Display P3 is shown with washed-out colours.
//
// Thread safety: a converter is immutable once made; convert() may run on any number of threads.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

namespace zoomwarp::tiles {

class IccToSrgb {
 public:
  // The converter for pixels of `channels` (3: RGB, 4: RGBA, alpha left as it is) tagged with
  // the profile in [icc, icc + size); null when there is nothing to do: no profile, fewer than 3
  // channels, or a profile that describes sRGB itself. Throws std::runtime_error, naming the
  // problem, for a profile LittleCMS cannot read or whose colour space is not RGB (a CMYK or
  // Lab source, which the pyramid could not show truthfully).
  static std::unique_ptr<IccToSrgb> for_profile(const std::uint8_t* icc, std::size_t size, int channels);

  ~IccToSrgb();
  IccToSrgb(const IccToSrgb&) = delete;
  IccToSrgb& operator=(const IccToSrgb&) = delete;

  // Converts `count` pixels in place.
  void convert(std::uint8_t* pixels, std::size_t count) const;

  // The profile's description, as it names itself ("Adobe RGB (1998)", "Display P3", …).
  const std::string& description() const { return description_; }

 private:
  IccToSrgb(void* transform, std::string description) : transform_(transform), description_(std::move(description)) {}

  void* transform_;  // cmsHTRANSFORM
  std::string description_;
};

}  // namespace zoomwarp::tiles
