#include "tiles/source_format.h"

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
  return "";
}

std::string sniff_image_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::uint8_t head[kSniffBytes] = {};
  in.read(reinterpret_cast<char*>(head), sizeof head);
  return sniff_image_format(head, std::size_t(in.gcount()));
}

}  // namespace zoomwarp::tiles
