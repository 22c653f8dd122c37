#include "tiles/header_sniff.h"

#include <cstring>

#include "tiles/source_format.h"

namespace zoomwarp::tiles {

namespace {

using Status = SniffedHeader::Status;

// Bounds-checked reads: every parser asks `has(at, len)` before reading.
class Bytes {
 public:
  Bytes(const std::uint8_t* p, std::size_t n, bool little = false) : p_(p), n_(n), little_(little) {}
  bool has(std::uint64_t at, std::uint64_t len) const { return at <= n_ && len <= n_ - at; }
  std::uint8_t u8(std::size_t at) const { return p_[at]; }
  std::uint64_t uint(std::size_t at, int len) const {
    std::uint64_t v = 0;
    for (int i = 0; i < len; ++i) v |= std::uint64_t(p_[at + (little_ ? i : len - 1 - i)]) << (8 * i);
    return v;
  }
  const std::uint8_t* at(std::size_t at) const { return p_ + at; }

 private:
  const std::uint8_t* p_;
  std::size_t n_;
  bool little_;
};

SniffedHeader make(Status status, std::string problem = "") {
  SniffedHeader h;
  h.status = status;
  h.problem = std::move(problem);
  return h;
}

SniffedHeader dimensions(std::uint64_t width, std::uint64_t height) {
  if (width == 0 || height == 0) return make(Status::kCorrupt, "the header declares an empty image");
  SniffedHeader h = make(Status::kOk);
  h.width = width;
  h.height = height;
  return h;
}

// JPEG (ITU T.81 §B.1.1.2-B.2.2): a chain of markers, each but SOI/EOI/RSTn/TEM followed by a
// two-byte length; the frame header SOFn holds the size. Any byte where a marker must be is 0xFF.
SniffedHeader sniff_jpeg(Bytes b) {
  std::uint64_t pos = 2;  // after SOI
  while (true) {
    if (!b.has(pos, 1)) return make(Status::kIncomplete);
    if (b.u8(pos) != 0xFF) return make(Status::kCorrupt, "the JPEG has no marker where one must be");
    while (b.has(pos, 1) && b.u8(pos) == 0xFF) ++pos;  // fill bytes
    if (!b.has(pos, 1)) return make(Status::kIncomplete);
    const std::uint8_t marker = b.u8(pos++);
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;  // no length
    if (marker == 0x00 || marker == 0xD8) return make(Status::kCorrupt, "the JPEG has an impossible marker");
    if (marker == 0xD9 || marker == 0xDA) return make(Status::kCorrupt, "the JPEG has no frame header before its data");
    if (!b.has(pos, 2)) return make(Status::kIncomplete);
    const std::uint64_t length = b.uint(pos, 2);
    if (length < 2) return make(Status::kCorrupt, "the JPEG has a segment of impossible length");
    const bool frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
    if (frame) {
      if (length < 8) return make(Status::kCorrupt, "the JPEG frame header is too short");
      if (!b.has(pos, 7)) return make(Status::kIncomplete);
      return dimensions(b.uint(pos + 5, 2), b.uint(pos + 3, 2));  // length, precision, Y, X
    }
    pos += length;
  }
}

std::uint32_t crc32(const std::uint8_t* p, std::size_t n) {  // PNG §5.5 (ISO 3309)
  std::uint32_t c = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < n; ++i) {
    c ^= p[i];
    for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
  }
  return c ^ 0xFFFFFFFFu;
}

// PNG (ISO 15948 §11.2.2): the signature, then IHDR first: length 13, width, height, bit depth,
// colour type, then its CRC — which also catches dimensions edited by hand.
SniffedHeader sniff_png(Bytes b) {
  if (!b.has(8, 8 + 13 + 4)) return make(Status::kIncomplete);
  if (b.uint(8, 4) != 13 || std::memcmp(b.at(12), "IHDR", 4) != 0)
    return make(Status::kCorrupt, "the PNG does not start with an IHDR chunk");
  if (crc32(b.at(12), 4 + 13) != b.uint(29, 4)) return make(Status::kCorrupt, "the PNG header's checksum is wrong");
  const std::uint64_t width = b.uint(16, 4), height = b.uint(20, 4);
  if (width > 0x7FFFFFFF || height > 0x7FFFFFFF) return make(Status::kCorrupt, "the PNG declares an impossible size");
  return dimensions(width, height);
}

// WebP (RFC 9649 §2.5-2.7): RIFF, then one of the chunks VP8 (lossy key frame header), VP8L
// (lossless signature and 14-bit sizes) or VP8X (extended, 24-bit canvas size).
SniffedHeader sniff_webp(Bytes b) {
  if (!b.has(12, 8)) return make(Status::kIncomplete);
  const std::string chunk(reinterpret_cast<const char*>(b.at(12)), 4);
  if (chunk == "VP8 ") {
    if (!b.has(20, 10)) return make(Status::kIncomplete);
    if ((b.u8(20) & 1) != 0 || b.u8(23) != 0x9D || b.u8(24) != 0x01 || b.u8(25) != 0x2A)
      return make(Status::kCorrupt, "the WebP does not start with a key frame");
    return dimensions(b.uint(26, 2) & 0x3FFF, b.uint(28, 2) & 0x3FFF);
  }
  if (chunk == "VP8L") {
    if (!b.has(20, 5)) return make(Status::kIncomplete);
    const std::uint64_t bits = b.uint(21, 4);
    if (b.u8(20) != 0x2F || (bits >> 29) != 0) return make(Status::kCorrupt, "the lossless WebP header is wrong");
    return dimensions((bits & 0x3FFF) + 1, ((bits >> 14) & 0x3FFF) + 1);
  }
  if (chunk == "VP8X") {
    if (!b.has(20, 10)) return make(Status::kIncomplete);
    return dimensions(b.uint(24, 3) + 1, b.uint(27, 3) + 1);
  }
  return make(Status::kCorrupt, "the WebP has no image chunk where one must be");
}

// TIFF 6.0 §2 and BigTIFF: byte order, version 42 (43), the offset of the first IFD, whose
// entries ImageWidth (256) and ImageLength (257) give the size. Writers often put the IFD after
// the pixels, so a first IFD beyond the bytes given is kIncomplete.
SniffedHeader sniff_tiff(Bytes b) {
  const bool big = b.uint(2, 2) == 43;
  const int offset_size = big ? 8 : 4, count_size = big ? 8 : 2, entry_size = big ? 20 : 12;
  const std::uint64_t header_size = big ? 16 : 8;
  if (!b.has(0, header_size)) return make(Status::kIncomplete);
  if (big && (b.uint(4, 2) != 8 || b.uint(6, 2) != 0)) return make(Status::kCorrupt, "the BigTIFF header is wrong");
  const std::uint64_t ifd = b.uint(big ? 8 : 4, offset_size);
  if (ifd < header_size) return make(Status::kCorrupt, "the TIFF's first directory offset is impossible");
  if (!b.has(ifd, count_size)) return make(Status::kIncomplete);
  const std::uint64_t entries = b.uint(ifd, count_size);
  std::uint64_t width = 0, height = 0;
  for (std::uint64_t i = 0; i < entries && (width == 0 || height == 0); ++i) {
    const std::uint64_t e = ifd + count_size + i * entry_size;
    if (!b.has(e, entry_size)) return make(Status::kIncomplete);
    const std::uint64_t tag = b.uint(e, 2), type = b.uint(e + 2, 2);
    if (tag != 256 && tag != 257) continue;
    const std::size_t value = e + 4 + offset_size;
    std::uint64_t v = 0;
    if (type == 3) v = b.uint(value, 2);                 // SHORT
    else if (type == 4) v = b.uint(value, 4);            // LONG
    else if (type == 16 && big) v = b.uint(value, 8);    // LONG8
    else return make(Status::kCorrupt, "the TIFF's image size has an impossible type");
    (tag == 256 ? width : height) = v;
  }
  if (width == 0 || height == 0) return make(Status::kCorrupt, "the TIFF's first directory has no image size");
  return dimensions(width, height);
}

}  // namespace

SniffedHeader sniff_image_header(const std::uint8_t* head, std::size_t n) {
  const std::string format = sniff_image_format(head, n);
  SniffedHeader h;
  if (format == "jpeg") h = sniff_jpeg(Bytes(head, n));
  else if (format == "png") h = sniff_png(Bytes(head, n));
  else if (format == "webp") h = sniff_webp(Bytes(head, n, true));
  else if (format == "tiff") h = sniff_tiff(Bytes(head, n, head[0] == 'I'));
  h.format = format;
  return h;
}

}  // namespace zoomwarp::tiles
