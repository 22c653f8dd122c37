// Reads an image's dimensions from its first bytes only — the start of an upload that is still
// arriving — so that a source in no accepted format, over the pixel limits or with an unreadable
// header is refused before the rest of its body is read or stored. Only the container headers
// are parsed (JPEG markers up to SOF, PNG IHDR, WebP VP8/VP8L/VP8X, TIFF's first IFD); the full
// decoder at ingest still checks everything else.
// Pure functions: safe to call from any thread.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace zoomwarp::tiles {

// How many first bytes of an upload are gathered for sniff_image_header(). A JPEG's SOF can sit
// behind this much EXIF, ICC and XMP; a header that needs more is kIncomplete, not refused.
inline constexpr std::size_t kHeaderSniffBytes = 64 * 1024;

struct SniffedHeader {
  enum class Status {
    kUnknownFormat,  // none of the formats ingest reads
    kIncomplete,     // a known format whose dimensions lie beyond the bytes given
    kCorrupt,        // a known format whose header cannot be right
    kOk,             // width and height are known
  };
  Status status = Status::kUnknownFormat;
  std::string format;     // as sniff_image_format(): "jpeg", "png", "tiff", "webp" or ""
  std::uint64_t width = 0, height = 0;
  std::string problem;    // for kCorrupt: what is wrong, for the client
};

// Parses the header in `head[0, n)`, the first n bytes of a file (fewer than the whole file is
// fine: that is the point). Never reads outside the n bytes, whatever they claim.
SniffedHeader sniff_image_header(const std::uint8_t* head, std::size_t n);

}  // namespace zoomwarp::tiles
