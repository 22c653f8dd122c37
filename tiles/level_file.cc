#include "tiles/level_file.h"

#include <isa-l/igzip_lib.h>
#include <libdeflate.h>
#include <tiffio.h>

#include <cstdarg>
#include <cstdio>
#include <new>
#include <span>
#include <stdexcept>

#include "tiles/ingest_error.h"

namespace zoomwarp::tiles {

namespace {

using Kind = IngestError::Kind;

// libtiff's mapping of a zip quality to a libdeflate level (tif_zip.c: levels 6 to 9 ask for one
// more, to compress as well as zlib does), so the files are the ones libtiff itself would write.
int deflate_level(int zip_quality) { return zip_quality >= 6 ? zip_quality + 1 : zip_quality; }

// Zip quality of "zip:N" / "zip", 0 for another compression.
int zip_quality(const std::string& compression) {
  if (compression == "zip") return 6;
  if (compression.size() == 5 && compression.rfind("zip:", 0) == 0 && compression[4] >= '1' && compression[4] <= '9')
    return compression[4] - '0';
  return 0;
}

// zip:1, the default, is compressed with ISA-L's igzip at level 1: on predicted photographs it is
// twice as fast as libdeflate's level 1 (214 vs 99 MB/s on the 123 MP panorama's tiles, one core)
// for 4 % more bytes (ratio 0.466 vs 0.444), and compression was half of ingest's CPU. The other
// zip levels, which ask for size over speed, use libdeflate at libtiff's levels.
constexpr int kIgzipQuality = 1;

// Compresses `in` as a zlib stream into `out` (resized to fit the worst case); returns its size.
std::size_t igzip_level1(std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  thread_local std::vector<std::uint8_t> level_buf(ISAL_DEF_LVL1_DEFAULT);  // igzip's hash tables
  // Stateless deflate needs room for all of it: at worst the input as stored blocks.
  out.resize(in.size() + in.size() / 1024 + 1024);
  isal_zstream z;  // 80 KB, mostly igzip's stateful buffers: not zeroed for each tile
  isal_deflate_stateless_init(&z);
  // ISA-L 2.30's init leaves the window size unset: stack garbage made the output depend on what
  // ran before (caught by tests/unit/ingest_threads_test.cc). 0: the default 32 KB window.
  z.hist_bits = 0;
  z.level = 1;
  z.level_buf = level_buf.data();
  z.level_buf_size = std::uint32_t(level_buf.size());
  z.gzip_flag = IGZIP_ZLIB;  // TIFF's deflate tiles are zlib streams
  z.next_in = const_cast<std::uint8_t*>(in.data());  // igzip does not write its input
  z.avail_in = std::uint32_t(in.size());
  z.next_out = out.data();
  z.avail_out = std::uint32_t(out.size());
  if (isal_deflate_stateless(&z) != COMP_OK) throw IngestError(Kind::kIo, "tile compression failed");
  return z.total_out;
}

// A compressor per thread and level: libdeflate's compressors are not thread-safe, and allocating
// one per tile would cost more than compressing a tile.
libdeflate_compressor* thread_compressor(int level) {
  struct Cached {
    int level = -1;
    std::unique_ptr<libdeflate_compressor, void (*)(libdeflate_compressor*)> compressor{nullptr,
                                                                                      libdeflate_free_compressor};
  };
  thread_local Cached cached;
  if (cached.level != level) {
    cached.compressor.reset(libdeflate_alloc_compressor(level));
    if (!cached.compressor) throw std::bad_alloc();
    cached.level = level;
  }
  return cached.compressor.get();
}

// The same with libdeflate at `level`.
std::size_t libdeflate_zlib(int level, std::span<const std::uint8_t> in, std::vector<std::uint8_t>& out) {
  libdeflate_compressor* c = thread_compressor(level);
  out.resize(libdeflate_zlib_compress_bound(c, in.size()));
  const std::size_t n = libdeflate_zlib_compress(c, in.data(), in.size(), out.data(), out.size());
  if (n == 0) throw IngestError(Kind::kIo, "tile compression failed");
  return n;
}

// TIFF predictor 2 (horizontal differencing) on 8-bit samples, row by row: each sample minus the
// same channel's sample one pixel to the left, the first pixel as is (TIFF 6.0 §14). Into `out`,
// not in place and not aliased, so that the loop vectorises.
void horizontal_difference(const std::uint8_t* __restrict in, int width, int height, int channels,
                           std::uint8_t* __restrict out) {
  const std::size_t row = std::size_t(width) * channels, ch = std::size_t(channels);
  for (int y = 0; y < height; ++y, in += row, out += row) {
    for (std::size_t i = 0; i < ch; ++i) out[i] = in[i];
    for (std::size_t i = ch; i < row; ++i) out[i] = std::uint8_t(in[i] - in[i - ch]);
  }
}

// libtiff reports through handlers; this one keeps the file's last message for the exception.
int keep_message(TIFF*, void* user_data, const char*, const char* fmt, va_list ap) {
  char text[512];
  std::vsnprintf(text, sizeof text, fmt, ap);
  *static_cast<std::string*>(user_data) = text;
  return 1;  // handled: nothing on stderr
}

// JPEG-in-TIFF's tags (TIFF Technical Note #2), as libtiff's JPEG codec writes them for YCbCr:
// the subsampling, ReferenceBlackWhite for full-range YCbCr (JFIF's), and the shared tables.
bool set_jpeg_tags(TIFF* t, const JpegTileFormat& f) {
  const std::vector<std::uint8_t> tables = jpeg_tile_tables(f);
  const float reference[6] = {0.f, 255.f, 128.f, 255.f, 128.f, 255.f};
  return TIFFSetField(t, TIFFTAG_PHOTOMETRIC, std::uint16_t(PHOTOMETRIC_YCBCR)) &&
         TIFFSetField(t, TIFFTAG_YCBCRSUBSAMPLING, std::uint16_t(f.chroma_h), std::uint16_t(f.chroma_v)) &&
         TIFFSetField(t, TIFFTAG_REFERENCEBLACKWHITE, reference) &&
         TIFFSetField(t, TIFFTAG_JPEGTABLES, std::uint32_t(tables.size()), tables.data());
}

}  // namespace

struct LevelFile::Tiff {
  TIFF* tif = nullptr;
  std::string path;
  std::string message;
  ~Tiff() {
    if (tif) TIFFClose(tif);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw IngestError(Kind::kIo, what + " " + path + (message.empty() ? "" : ": " + message));
  }
};

LevelFile::LevelFile(const std::string& path, int width, int height, int channels, int tile_size,
                     const LevelCompression& level_compression)
    : tiff_(std::make_unique<Tiff>()) {
  const std::string& compression = level_compression.method;
  const int quality = zip_quality(compression);
  const bool jpeg = compression == "jpeg";
  if (quality == 0 && !jpeg && compression != "lzw" && compression != "none")
    throw std::invalid_argument("unknown tile compression '" + compression + "'");
  if (jpeg && (channels != 3 || !is_valid(level_compression.jpeg) || tile_size % 16 != 0))
    throw std::invalid_argument("JPEG tiles need RGB, a valid quality and subsampling, and tiles a multiple of 16");
  encoder_.tile_size_ = tile_size;
  encoder_.channels_ = channels;
  encoder_.zip_quality_ = quality;
  encoder_.jpeg_ = jpeg;
  encoder_.jpeg_format_ = level_compression.jpeg;
  libtiff_encodes_ = compression == "lzw";

  tiff_->path = path;
  TIFFOpenOptions* opts = TIFFOpenOptionsAlloc();
  TIFFOpenOptionsSetErrorHandlerExtR(opts, keep_message, &tiff_->message);
  TIFFOpenOptionsSetWarningHandlerExtR(opts, keep_message, &tiff_->message);
  // Classic TIFF offsets are 32-bit: past 4000 MiB of raw pixels, BigTIFF (as OpenImageIO decided).
  const bool big = std::uint64_t(width) * height * channels > 4000ULL << 20;
  tiff_->tif = TIFFOpenExt(path.c_str(), big ? "w8" : "w", opts);
  TIFFOpenOptionsFree(opts);
  if (!tiff_->tif) tiff_->fail("cannot create");

  TIFF* t = tiff_->tif;
  const std::uint16_t unspecified = EXTRASAMPLE_UNSPECIFIED;
  const bool ok =
      TIFFSetField(t, TIFFTAG_IMAGEWIDTH, std::uint32_t(width)) && TIFFSetField(t, TIFFTAG_IMAGELENGTH, std::uint32_t(height)) &&
      TIFFSetField(t, TIFFTAG_TILEWIDTH, std::uint32_t(tile_size)) &&
      TIFFSetField(t, TIFFTAG_TILELENGTH, std::uint32_t(tile_size)) &&
      TIFFSetField(t, TIFFTAG_SAMPLESPERPIXEL, std::uint16_t(channels)) &&
      TIFFSetField(t, TIFFTAG_BITSPERSAMPLE, std::uint16_t(8)) &&
      TIFFSetField(t, TIFFTAG_SAMPLEFORMAT, std::uint16_t(SAMPLEFORMAT_UINT)) &&
      TIFFSetField(t, TIFFTAG_ORIENTATION, std::uint16_t(ORIENTATION_TOPLEFT)) &&
      TIFFSetField(t, TIFFTAG_PLANARCONFIG, std::uint16_t(PLANARCONFIG_CONTIG)) &&
      TIFFSetField(t, TIFFTAG_COMPRESSION,
                   std::uint16_t(jpeg      ? COMPRESSION_JPEG
                                 : quality ? COMPRESSION_ADOBE_DEFLATE
                                 : libtiff_encodes_ ? COMPRESSION_LZW
                                                    : COMPRESSION_NONE)) &&
      (jpeg ? set_jpeg_tags(t, level_compression.jpeg) : TIFFSetField(t, TIFFTAG_PHOTOMETRIC, std::uint16_t(PHOTOMETRIC_RGB))) &&
      (compression == "none" || jpeg || TIFFSetField(t, TIFFTAG_PREDICTOR, std::uint16_t(PREDICTOR_HORIZONTAL))) &&
      // Straight alpha, stored as an unspecified extra sample so that no reader premultiplies it.
      (channels != 4 || TIFFSetField(t, TIFFTAG_EXTRASAMPLES, std::uint16_t(1), &unspecified)) &&
      TIFFSetField(t, TIFFTAG_SOFTWARE, "zoomwarp");
  if (!ok) tiff_->fail("cannot set up");
}

LevelFile::~LevelFile() = default;

std::vector<std::uint8_t> TileEncoder::operator()(std::span<const std::uint8_t> tile) const {
  if (jpeg_) return encode_jpeg_tile(jpeg_format_, tile, tile_size_);
  if (zip_quality_ == 0) return {tile.begin(), tile.end()};  // none, or libtiff encodes (lzw)
  thread_local std::vector<std::uint8_t> predicted;
  predicted.resize(tile.size());
  horizontal_difference(tile.data(), tile_size_, tile_size_, channels_, predicted.data());
  // Compressed into scratch and copied out at its size: the tiles in flight hold only their bytes.
  thread_local std::vector<std::uint8_t> scratch;
  const std::size_t n = zip_quality_ == kIgzipQuality ? igzip_level1(predicted, scratch)
                                                       : libdeflate_zlib(deflate_level(zip_quality_), predicted, scratch);
  return {scratch.begin(), scratch.begin() + std::ptrdiff_t(n)};
}

void LevelFile::write(int tx, int ty, std::span<std::uint8_t> encoded) {
  TIFF* t = tiff_->tif;
  const auto ts = std::uint32_t(encoder_.tile_size());
  const std::uint32_t index = TIFFComputeTile(t, std::uint32_t(tx) * ts, std::uint32_t(ty) * ts, 0, 0);
  const tmsize_t n = tmsize_t(encoded.size());
  const tmsize_t written = libtiff_encodes_ ? TIFFWriteEncodedTile(t, index, encoded.data(), n)
                                            : TIFFWriteRawTile(t, index, encoded.data(), n);
  if (written < 0) tiff_->fail("cannot write tiles of");
}

void LevelFile::close() {
  const bool ok = TIFFFlush(tiff_->tif) == 1;
  TIFFClose(tiff_->tif);
  tiff_->tif = nullptr;
  if (!ok) tiff_->fail("cannot finish");
}

}  // namespace zoomwarp::tiles
