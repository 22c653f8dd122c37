#include "tiles/source_format.h"

#include <algorithm>
#include <cstring>
#include <fstream>

namespace zoomwarp::tiles {

std::string sniff_image_format(const std::uint8_t* h, std::size_t n) {
  auto starts = [&](const char* magic, std::size_t len, std::size_t at = 0) {
    return n >= at + len && std::memcmp(h + at, magic, len) == 0;
  };
  if (starts("\xFF\xD8\xFF", 3)) return "jpeg";
  if (starts("\x89PNG\r\n\x1A\n", 8)) return "png";
  if (starts("II*\0", 4) || starts("MM\0*", 4) || starts("II+\0", 4) || starts("MM\0+", 4))
    return "tiff";  // classic and BigTIFF
  if (starts("RIFF", 4) && starts("WEBP", 4, 8)) return "webp";
  // JPEG 2000: the JP2 signature box (ISO 15444-1 §I.5.1), or a bare codestream's SOC and SIZ
  // markers (§A.4.1, A.5.1). High-Throughput JPEG 2000 (Part 15) has the same containers.
  if (starts("\0\0\0\x0CjP  \r\n\x87\n", 12)) return "jp2";
  if (starts("\xFF\x4F\xFF\x51", 4)) return "j2k";
  // HEIF (ISO 23008-12) and AVIF: an ISO BMFF 'ftyp' box first, its major brand and then its
  // compatible brands (as far as the bytes go) naming the image kind.
  if (starts("ftyp", 4, 4) && n >= 12) {
    const std::size_t box = std::min<std::size_t>(n, (std::size_t(h[0]) << 24) | (std::size_t(h[1]) << 16) |
                                                         (std::size_t(h[2]) << 8) | std::size_t(h[3]));
    auto brand = [&](std::size_t at) { return std::string(reinterpret_cast<const char*>(h + at), 4); };
    const auto is_avif = [](const std::string& b) { return b == "avif" || b == "avis"; };
    const auto is_heic = [](const std::string& b) {
      return b == "heic" || b == "heix" || b == "heim" || b == "heis" || b == "hevc" || b == "hevx";
    };
    const std::string major = brand(8);
    if (is_avif(major)) return "avif";
    if (is_heic(major)) return "heif";
    if (major == "mif1" || major == "msf1") {
      for (std::size_t at = 16; at + 4 <= box; at += 4) {
        if (is_avif(brand(at))) return "avif";
        if (is_heic(brand(at))) return "heif";
      }
      return "heif";
    }
  }
  return "";
}

std::string sniff_image_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint8_t head[kSniffBytes] = {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  return sniff_image_format(head, std::size_t(in.gcount()));
}

}  // namespace zoomwarp::tiles
