#include "tiles/source_compression.h"

// jpeglib.h needs size_t and FILE declared first.
#include <cstddef>
#include <cstdio>
#include <csetjmp>
#include <jpeglib.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <memory>

namespace zoomwarp::tiles {

namespace {

// ITU-T T.81 Annex K, Table K.1 (luminance), natural order: what libjpeg scales by quality.
constexpr unsigned short kAnnexKLuma[64] = {
    16, 11, 10, 16, 24,  40,  51,  61,  12, 12, 14, 19, 26,  58,  60,  55,
    14, 13, 16, 24, 40,  57,  69,  56,  14, 17, 22, 29, 51,  87,  80,  62,
    18, 22, 37, 56, 68,  109, 103, 77,  24, 35, 55, 64, 81,  104, 113, 92,
    49, 64, 78, 87, 103, 121, 120, 101, 72, 92, 95, 98, 112, 100, 103, 99};

struct ErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
};
[[noreturn]] void jump_back(j_common_ptr c) { std::longjmp(reinterpret_cast<ErrorManager*>(c->err)->jump, 1); }
void no_message(j_common_ptr) {}

// The JPEG's header (up to its first scan) read by libjpeg; nullopt if libjpeg refuses it.
std::optional<JpegTileFormat> read_jpeg_format(std::FILE* file) {
  jpeg_decompress_struct d{};
  ErrorManager err{};
  d.err = jpeg_std_error(&err.pub);
  err.pub.error_exit = jump_back;
  err.pub.output_message = no_message;
  if (setjmp(err.jump)) {
    jpeg_destroy_decompress(&d);
    return std::nullopt;
  }
  jpeg_create_decompress(&d);
  jpeg_stdio_src(&d, file);
  jpeg_read_header(&d, TRUE);
  const JQUANT_TBL* luma = d.comp_info[0].quant_table ? d.comp_info[0].quant_table : d.quant_tbl_ptrs[0];
  std::optional<JpegTileFormat> f;
  if (luma) {
    unsigned short table[64];
    for (int i = 0; i < 64; ++i) table[i] = luma->quantval[i];
    f = JpegTileFormat{ijg_quality_of(table), 2, 2};
    // Colour sources keep their subsampling when the tiles can store it; grey ones (expanded to
    // RGB, no chroma at all) and others get 4:2:0.
    if (d.num_components == 3 && d.comp_info[1].h_samp_factor == 1 && d.comp_info[1].v_samp_factor == 1 &&
        d.comp_info[2].h_samp_factor == 1 && d.comp_info[2].v_samp_factor == 1) {
      const JpegTileFormat same{f->quality, d.comp_info[0].h_samp_factor, d.comp_info[0].v_samp_factor};
      if (is_valid(same)) f = same;
    }
  }
  jpeg_destroy_decompress(&d);
  return f;
}

// Whether a WebP's image is lossy: a simple file's first chunk, or an extended file's first
// VP8/VP8L chunk (after ICCP, ANIM, ALPH …; RFC 9649 §2.7) within its first 64 KiB.
bool webp_is_lossy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(64 * 1024, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(in.gcount()));
  for (std::size_t at = 12; at + 8 <= head.size();) {
    const std::string chunk = head.substr(at, 4);
    if (chunk == "VP8 ") return true;
    if (chunk == "VP8L") return false;
    const auto* s = reinterpret_cast<const unsigned char*>(head.data() + at + 4);
    const std::size_t size = std::size_t(s[0]) | std::size_t(s[1]) << 8 | std::size_t(s[2]) << 16 | std::size_t(s[3]) << 24;
    at += 8 + size + (size & 1);  // chunks are padded to even sizes
  }
  return false;
}

// Whether a JPEG 2000 codestream's wavelet is the irreversible 9-7 (lossy) rather than the
// reversible 5-3 (lossless when every layer is kept, as a master's is): the COD marker's
// "transformation" byte (ISO 15444-1 §A.6.1, Table A.20: 0 = 9-7, 1 = 5-3). COD is in the main
// header after SIZ, so it lies in the first KiB of a JP2's codestream box; the codestream is
// found by its SOC + SIZ markers, and the main header walked marker by marker up to SOT.
bool jpeg2000_is_lossy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string head(64 * 1024, '\0');
  in.read(head.data(), std::streamsize(head.size()));
  head.resize(std::size_t(in.gcount()));
  const auto* h = reinterpret_cast<const unsigned char*>(head.data());
  std::size_t at = head.find("\xFF\x4F\xFF\x51");
  if (at == std::string::npos) return true;  // unreadable: the safe side is JPEG tiles
  at += 2;
  while (at + 4 <= head.size() && h[at] == 0xFF) {
    const int marker = h[at + 1];
    const std::size_t length = std::size_t(h[at + 2]) << 8 | h[at + 3];
    if (marker == 0x90 || length < 2) break;  // SOT: the main header is over
    if (marker == 0x52 && length >= 12 && at + 2 + 12 <= head.size()) return h[at + 2 + 11] == 0;
    at += 2 + length;
  }
  return true;
}

}  // namespace

int ijg_quality_of(const unsigned short (&table)[64]) {
  int best = 100;
  long best_error = -1;
  for (int q = 100; q >= 1; --q) {
    const long scale = jpeg_quality_scaling(q);
    long error = 0;
    for (int i = 0; i < 64; ++i) {
      const long v = std::clamp((kAnnexKLuma[i] * scale + 50) / 100, 1L, 255L);  // jcparam.c, baseline
      error += std::labs(v - long(table[i]));
    }
    if (best_error < 0 || error < best_error) best = q, best_error = error;
  }
  return best;
}

SourceCompression source_compression(const std::string& path, const std::string& format) {
  SourceCompression s;
  if (format == "jpeg") {
    s.lossy = true;
    std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), std::fclose);
    if (file) s.jpeg = read_jpeg_format(file.get());
  } else if (format == "webp") {
    s.lossy = webp_is_lossy(path);
  } else if (format == "jp2" || format == "j2k") {
    s.lossy = jpeg2000_is_lossy(path);
  } else if (format == "heif" || format == "avif") {
    s.lossy = true;  // HEVC and AV1 as these files carry them: lossy (tiles/README.md)
  }
  return s;
}

}  // namespace zoomwarp::tiles
