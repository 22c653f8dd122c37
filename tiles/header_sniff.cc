#include "tiles/header_sniff.h"

#include <algorithm>
#include <cstring>
#include <string>

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

// A JPEG 2000 codestream (ISO 15444-1 §A.5.1): SOC, then SIZ: Lsiz, Rsiz, Xsiz, Ysiz, XOsiz,
// YOsiz — the image area is [XOsiz, Xsiz) × [YOsiz, Ysiz) of the reference grid.
SniffedHeader sniff_codestream(Bytes b, std::uint64_t at) {
  if (!b.has(at, 4 + 2 + 2 + 16)) return make(Status::kIncomplete);
  if (b.uint(at, 2) != 0xFF4F || b.uint(at + 2, 2) != 0xFF51)
    return make(Status::kCorrupt, "the JPEG 2000 codestream does not start with SOC and SIZ");
  const std::uint64_t x = b.uint(at + 8, 4), y = b.uint(at + 12, 4), x0 = b.uint(at + 16, 4), y0 = b.uint(at + 20, 4);
  if (x0 >= x || y0 >= y) return make(Status::kCorrupt, "the JPEG 2000 image area is empty");
  return dimensions(x - x0, y - y0);
}

// ISO BMFF boxes (ISO 14496-12 §4.2), as JP2 (15444-1 §I.4) and HEIF use them: a 32-bit size
// (1: a 64-bit one follows the type; 0: to the end of the file) and a 4-character type. Calls
// box(type, payload start, end) for each box in [from, to) until it returns false; stops with
// kIncomplete where a box's header lies beyond the bytes given, kCorrupt where a size is impossible.
template <typename Visit>
Status walk_boxes(Bytes b, std::uint64_t from, std::uint64_t to, Visit&& box) {
  for (std::uint64_t at = from; at < to;) {
    if (!b.has(at, 8)) return Status::kIncomplete;
    std::uint64_t size = b.uint(at, 4), header = 8;
    if (size == 1) {
      if (!b.has(at + 8, 8)) return Status::kIncomplete;
      size = b.uint(at + 8, 8), header = 16;
    } else if (size == 0) {
      size = to - at;
    }
    if (size < header || size > to - at) return Status::kCorrupt;
    const std::string type(reinterpret_cast<const char*>(b.at(at + 4)), 4);
    if (!box(type, at + header, at + size)) return Status::kOk;
    at += size;
  }
  return Status::kOk;
}

constexpr std::uint64_t kWholeFile = ~std::uint64_t(0) >> 1;

// JP2 (ISO 15444-1 §I.5.3): the JP2 Header box 'jp2h' holds the Image Header box 'ihdr' first:
// HEIGHT, WIDTH (4 bytes each), then NC, BPC, C, UnkC, IPR. It must come before the codestream.
SniffedHeader sniff_jp2(Bytes b) {
  SniffedHeader found = make(Status::kIncomplete);
  bool codestream_first = false;
  const Status walked = walk_boxes(b, 0, kWholeFile, [&](const std::string& type, std::uint64_t begin, std::uint64_t end) {
    if (type == "jp2c") return codestream_first = true, false;
    if (type != "jp2h") return true;
    if (!b.has(begin, 8 + 8)) return false;  // kIncomplete
    if (b.uint(begin, 4) < 8 + 14 || std::memcmp(b.at(begin + 4), "ihdr", 4) != 0 || end - begin < 8 + 14) {
      found = make(Status::kCorrupt, "the JP2 header box does not start with an image header");
      return false;
    }
    found = dimensions(b.uint(begin + 12, 4), b.uint(begin + 8, 4));
    return false;
  });
  if (codestream_first) return make(Status::kCorrupt, "the JP2 has no header box before its codestream");
  if (walked == Status::kCorrupt) return make(Status::kCorrupt, "the JP2 has a box of impossible size");
  return found;
}

// HEIF (ISO 23008-12 §6) and AVIF: the 'meta' box's item properties ('iprp' → 'ipco') hold an
// Image Spatial Extents property 'ispe' (version and flags, width, height) for every image item —
// the primary image, the tiles of a grid, thumbnails. The largest extents bound what decoding
// can produce, which is all the limits need; without them (a 'meta' after the media data, beyond
// the bytes given) the decoder decides.
SniffedHeader sniff_heif(Bytes b) {
  std::uint64_t width = 0, height = 0;
  bool corrupt = false;
  // Descends into the first box of `type` in [begin, end) and calls inside(payload begin, end).
  auto first = [&](std::uint64_t begin, std::uint64_t end, const char* type, auto&& inside) {
    corrupt |= walk_boxes(b, begin, end, [&](const std::string& t, std::uint64_t b1, std::uint64_t e1) {
                 if (t != type) return true;
                 inside(b1, e1);
                 return false;
               }) == Status::kCorrupt;
  };
  first(0, kWholeFile, "meta", [&](std::uint64_t meta, std::uint64_t meta_end) {
    // 'meta' is a full box: version and flags before its children.
    first(meta + 4, meta_end, "iprp", [&](std::uint64_t iprp, std::uint64_t iprp_end) {
      first(iprp, iprp_end, "ipco", [&](std::uint64_t ipco, std::uint64_t ipco_end) {
        corrupt |= walk_boxes(b, ipco, ipco_end, [&](const std::string& t, std::uint64_t p, std::uint64_t) {
                     if (t == "ispe" && b.has(p, 12))
                       width = std::max(width, b.uint(p + 4, 4)), height = std::max(height, b.uint(p + 8, 4));
                     return true;
                   }) == Status::kCorrupt;
      });
    });
  });
  if (corrupt) return make(Status::kCorrupt, "the HEIF has a box of impossible size");
  if (width > 0 && height > 0) return dimensions(width, height);
  return make(Status::kIncomplete);  // no extents in the bytes given: the decoder decides
}

}  // namespace

SniffedHeader sniff_image_header(const std::uint8_t* head, std::size_t n) {
  const std::string format = sniff_image_format(head, n);
  SniffedHeader h;
  if (format == "jpeg") h = sniff_jpeg(Bytes(head, n));
  else if (format == "png") h = sniff_png(Bytes(head, n));
  else if (format == "webp") h = sniff_webp(Bytes(head, n, true));
  else if (format == "tiff") h = sniff_tiff(Bytes(head, n, head[0] == 'I'));
  else if (format == "jp2") h = sniff_jp2(Bytes(head, n));
  else if (format == "j2k") h = sniff_codestream(Bytes(head, n), 0);
  else if (format == "heif" || format == "avif") h = sniff_heif(Bytes(head, n));
  h.format = format;
  return h;
}

}  // namespace zoomwarp::tiles
