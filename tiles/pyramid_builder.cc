#include "tiles/pyramid_builder.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "tiles/header_sniff.h"
#include "tiles/icc_to_srgb.h"
#include "tiles/jpeg2000_rows.h"
#include "tiles/level_file.h"
#include "tiles/manifest.h"
#include "tiles/source_compression.h"
#include "tiles/source_format.h"
#include "tiles/strip_pipeline.h"

namespace zoomwarp::tiles {

namespace {

using Kind = IngestError::Kind;

// Averages two rows (b may be a, for the last row of an odd height) into one row of half the
// width, rounded up, from output column `x` on; an odd last column averages with itself. With
// alpha, colours are weighted by alpha so that invisible pixels do not bleed their colour into the
// coarser levels.
void halve_pair(const std::uint8_t* a, const std::uint8_t* b, int w, int ch, int x, std::uint8_t* out) {
  for (const int half = (w + 1) / 2; x < half; ++x) {
    const int x0 = 2 * x, x1 = std::min(2 * x + 1, w - 1);
    const std::uint8_t* p[4] = {a + x0 * ch, a + x1 * ch, b + x0 * ch, b + x1 * ch};
    std::uint8_t* o = out + x * ch;
    if (ch == 4) {
      unsigned alpha = p[0][3] + p[1][3] + p[2][3] + p[3][3];
      for (int c = 0; c < 3; ++c) {
        unsigned s = alpha ? (p[0][c] * p[0][3] + p[1][c] * p[1][3] + p[2][c] * p[2][3] +
                              p[3][c] * p[3][3] + alpha / 2) / alpha
                           : (p[0][c] + p[1][c] + p[2][c] + p[3][c] + 2) / 4;
        o[c] = std::uint8_t(s);
      }
      o[3] = std::uint8_t((alpha + 2) / 4);
    } else {
      for (int c = 0; c < ch; ++c) o[c] = std::uint8_t((p[0][c] + p[1][c] + p[2][c] + p[3][c] + 2) / 4);
    }
  }
}

// Halves `pairs` pairs of consecutive rows at `rows` (w pixels of ch channels each) into as many
// rows at `out`, as halve_pair() does. Opaque RGB goes through OpenCV's 2×2 area reduction, SIMD,
// the same (sum + 2) / 4 — half of the decoding thread's halving time on the 952 MP image, and
// that thread is the pyramid's critical path — called once for every pair given, not per pair:
// each call allocates and frees its width's buffers, which at a 31 872 px width made glibc trim
// its heap (brk, a TLB flush on every core) twice per pair of rows, 16 % of the ingest's CPU.
void halve_rows(const std::uint8_t* rows, int pairs, int w, int ch, std::uint8_t* out) {
  const std::size_t in_row = std::size_t(w) * ch, out_row = std::size_t((w + 1) / 2) * ch;
  int x = 0;
  if (ch == 3 && w >= 2) {
    const cv::Mat in(2 * pairs, w & ~1, CV_8UC3, const_cast<std::uint8_t*>(rows), in_row);
    cv::Mat halved(pairs, w / 2, CV_8UC3, out, out_row);
    cv::resize(in, halved, halved.size(), 0, 0, cv::INTER_AREA);
    x = w / 2;
  }
  for (int p = 0; p < pairs; ++p) {
    const std::uint8_t* a = rows + 2 * std::size_t(p) * in_row;
    halve_pair(a, a + in_row, w, ch, x, out + std::size_t(p) * out_row);
  }
}

// One level being written. Its rows are written straight into a strip one tile high (by the
// decoder, or by halving the finer level); each pair of rows is halved into the next coarser level
// as it arrives, and each full strip is handed to the pipeline (encoded there, written in order).
// Strips start at even rows (the tile size is even), so pairs never straddle two strips.
class LevelWriter {
 public:
  LevelWriter(const std::string& dir, int level, int w, int h, int ch, const PyramidOptions& opt,
              const LevelCompression& compression, StripPipeline& pipeline)
      : file_(dir + "/" + level_filename(level), w, h, ch, opt.tile_size, compression),
        pipeline_(pipeline), w_(w), ch_(ch), tile_(opt.tile_size), strip_(new_strip()) {
    if (w > 1 || h > 1)
      next_ = std::make_unique<LevelWriter>(dir, level + 1, (w + 1) / 2, (h + 1) / 2, ch, opt, compression, pipeline);
  }

  // Where the next rows go, and how many fit before the strip is full: the caller writes up to
  // rows_free() rows there, then calls add_rows().
  std::uint8_t* free_rows() { return row(strip_rows_); }
  int rows_free() const { return tile_ - strip_rows_; }

  // Every whole pair of rows not yet halved goes to the next level, as many at once as fit in its
  // strip; a level fed one row at a time keeps an odd row until its pair comes.
  void add_rows(int n) {
    strip_rows_ += n;
    while (next_ && strip_rows_ - halved_rows_ >= 2) {
      const int pairs = std::min((strip_rows_ - halved_rows_) / 2, next_->rows_free());
      halve_rows(row(halved_rows_), pairs, w_, ch_, next_->free_rows());
      halved_rows_ += 2 * pairs;
      next_->add_rows(pairs);
    }
    if (strip_rows_ == tile_) flush_strip();
  }

  // Hands over the last partial strips of this level and the coarser ones; an odd last row is
  // halved with itself.
  void flush() {
    if (strip_rows_ % 2 == 1 && next_) {
      halve_pair(row(strip_rows_ - 1), row(strip_rows_ - 1), w_, ch_, 0, next_->free_rows());
      next_->add_rows(1);
    }
    if (strip_rows_ > 0) flush_strip();
    if (next_) next_->flush();
  }

  // After the pipeline is drained: closes this level's file and the coarser ones.
  void close() {
    file_.close();
    if (next_) next_->close();
  }

 private:
  std::uint8_t* row(int r) { return strip_.get() + std::size_t(r) * w_ * ch_; }

  // Not zeroed: only written rows are read (the pipeline pads a partial strip from its last row).
  std::unique_ptr<std::uint8_t[]> new_strip() { return pipeline_.strip_buffer(std::size_t(tile_) * w_ * ch_); }

  void flush_strip() {
    pipeline_.submit(file_, strip_y_ / tile_, w_, strip_rows_, std::move(strip_));
    strip_ = new_strip();
    strip_y_ += strip_rows_;
    strip_rows_ = halved_rows_ = 0;
  }

  LevelFile file_;
  StripPipeline& pipeline_;
  int w_, ch_, tile_;
  std::unique_ptr<std::uint8_t[]> strip_;
  int strip_rows_ = 0, strip_y_ = 0;
  int halved_rows_ = 0;  // rows of the strip already halved into the next level (even)
  std::unique_ptr<LevelWriter> next_;
};

// Stored channels: grey becomes RGB, grey+alpha RGBA, extra channels beyond RGBA are dropped.
int stored_channels(const OIIO::ImageSpec& spec) {
  if (spec.nchannels == 2) return 4;
  if (spec.nchannels >= 4 && spec.alpha_channel == 3) return 4;
  if (spec.nchannels == 4 && spec.alpha_channel < 0) return 4;  // RGBA without the tag
  return 3;
}

// Maps `n` source pixels with `src_ch` channels to RGB(A).
void to_stored(const std::uint8_t* src, int src_ch, int n, int ch, std::uint8_t* dst) {
  for (int i = 0; i < n; ++i, src += src_ch, dst += ch) {
    if (src_ch <= 2) {
      dst[0] = dst[1] = dst[2] = src[0];
      if (ch == 4) dst[3] = src_ch == 2 ? src[1] : 255;
    } else {
      dst[0] = src[0], dst[1] = src[1], dst[2] = src[2];
      if (ch == 4) dst[3] = src[3];
    }
  }
}

// The levels' compression for this source (PyramidOptions::compression).
LevelCompression choose_compression(const PyramidOptions& options, const std::string& path, const PyramidInfo& info) {
  const bool auto_choice = options.compression == "auto";
  if (!auto_choice && options.compression != "jpeg") return {options.compression, {}};
  const SourceCompression source = source_compression(path, info.source_format);
  if (info.channels != 3 || (auto_choice && !source.lossy)) return {"zip:1", {}};
  JpegTileFormat jpeg{options.jpeg_quality, 2, 2};
  if (source.jpeg) jpeg = {std::min(options.jpeg_quality, source.jpeg->quality), source.jpeg->chroma_h, source.jpeg->chroma_v};
  return {"jpeg", jpeg};
}

bool over_limits(std::uint64_t width, std::uint64_t height, const SourceLimits& limits) {
  const auto side = std::uint64_t(limits.max_dimension);
  return width > side || height > side || width * height > limits.max_pixels;
}

std::string too_large_message(std::uint64_t width, std::uint64_t height, const SourceLimits& limits) {
  return "image is " + std::to_string(width) + "x" + std::to_string(height) + " pixels, over the limit of " +
         std::to_string(limits.max_pixels) + " pixels";
}

// The width and height the file's header declares (tiles/header_sniff.h), if its first bytes say.
std::optional<std::pair<std::uint64_t, std::uint64_t>> declared_size(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> head(kHeaderSniffBytes);
  in.read(reinterpret_cast<char*>(head.data()), std::streamsize(head.size()));
  const SniffedHeader h = sniff_image_header(head.data(), std::size_t(in.gcount()));
  if (h.status != SniffedHeader::Status::kOk) return std::nullopt;
  return std::make_pair(h.width, h.height);
}

// OpenImageIO's name of the reader of a format sniff_image_file() names.
std::string oiio_format_name(const std::string& sniffed) {
  if (sniffed == "jp2" || sniffed == "j2k") return "jpeg2000";
  if (sniffed == "avif") return "heif";
  return sniffed;  // jpeg, png, tiff, webp, heif: the same names
}

struct OpenSource {
  // A JPEG 2000 codestream OpenJPEG reads tile by tile (jpeg2000_rows.h); else OpenImageIO's reader.
  std::unique_ptr<Jpeg2000Rows> jpeg2000;
  std::unique_ptr<OIIO::ImageInput> input;
  int source_width = 0, source_height = 0;  // before orientation
  PyramidInfo info;
  int read_channels = 3;  // source channels we read (≤ 4)
  int subimage = 0;       // the page read: the largest (a pyramidal TIFF's full resolution)
  std::unique_ptr<IccToSrgb> icc;  // the embedded profile's conversion to sRGB, if it needs one
};

// Bytes a decode of the whole image at once holds: OpenImageIO's JPEG 2000 reader (OpenJPEG's
// 32-bit samples, then its own copy), a reorientation (the decoded image and the turned one).
std::uint64_t whole_decode_bytes(std::uint64_t width, std::uint64_t height, int components, int sample_bytes) {
  return width * height * std::uint64_t(components) * std::uint64_t(sample_bytes);
}

void check_decode_memory(std::uint64_t bytes, const SourceLimits& limits, const std::string& why) {
  if (bytes > limits.max_decode_bytes)
    throw IngestError(Kind::kTooLarge, why + ", which needs " + std::to_string(bytes >> 20) + " MiB, over the limit of " +
                                           std::to_string(limits.max_decode_bytes >> 20) + " MiB (--max-decode-memory)");
}

// A JPEG 2000 source OpenJPEG can read by tiles or bands, with its channels and ICC profile; null
// for one it cannot (decoded whole by OpenImageIO, within the memory limit).
bool open_jpeg2000(const std::string& path, const SourceLimits& limits, int threads, OpenSource& s) {
  auto j2k = std::make_unique<Jpeg2000Rows>(path, s.info.source_format, threads);
  const std::uint64_t w = std::uint64_t(j2k->width()), h = std::uint64_t(j2k->height());
  if (over_limits(w, h, limits)) throw IngestError(Kind::kTooLarge, too_large_message(w, h, limits));
  if (!j2k->supported()) {
    check_decode_memory(whole_decode_bytes(w, h, j2k->components(), 4 + 1), limits,
                        "this JPEG 2000 image must be decoded whole (" + j2k->why_not() + ")");
    return false;
  }
  check_decode_memory(j2k->peak_bytes(), limits, "this JPEG 2000 image's tiles or bands are too large to decode");
  s.source_width = j2k->width(), s.source_height = j2k->height();
  s.read_channels = std::min(j2k->components(), 4);
  if (!j2k->icc_profile().empty()) {
    try {
      s.icc = IccToSrgb::for_profile(j2k->icc_profile().data(), j2k->icc_profile().size(), s.read_channels);
    } catch (const std::runtime_error& e) {
      throw IngestError(Kind::kCorrupt, std::string("the image cannot be shown in sRGB: ") + e.what());
    }
  }
  s.info.channels = j2k->components() == 2 || j2k->components() >= 4 ? 4 : 3;
  s.info.source_channels = j2k->components();
  s.info.source_bits = j2k->bits() <= 8 ? 8 : 16;
  s.info.width = j2k->width(), s.info.height = j2k->height();
  s.info.levels = pyramid_levels(s.info.width, s.info.height);
  s.jpeg2000 = std::move(j2k);
  return true;
}

OpenSource open_source(const std::string& path, const SourceLimits& limits, int threads) {
  OpenSource s;
  s.info.source_format = sniff_image_file(path);
  if (s.info.source_format.empty())
    throw IngestError(Kind::kUnsupportedFormat,
                      "unsupported image format (JPEG, PNG, TIFF, WebP, JPEG 2000, HEIF and AVIF are accepted)");
  // The size the header declares, checked before any decoder runs: OpenImageIO's JPEG 2000
  // reader decodes the whole image when it opens it, so a small file declaring a huge one would
  // be decoded before the limits below could refuse it.
  if (const auto declared = declared_size(path); declared && over_limits(declared->first, declared->second, limits))
    throw IngestError(Kind::kTooLarge, too_large_message(declared->first, declared->second, limits));
  if ((s.info.source_format == "jp2" || s.info.source_format == "j2k") && open_jpeg2000(path, limits, threads, s)) return s;
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // keep alpha straight, as the file has it
  // The sniffed format's reader, opened once. Given a file name, ImageInput::open() opens the
  // file to check its type, closes it and opens it again, and OpenImageIO 2.4's JPEG 2000 reader
  // decodes the whole image at every open: a JP2 was decoded twice per open.
  s.input = OIIO::ImageInput::create(oiio_format_name(s.info.source_format));
  OIIO::ImageSpec opened;
  if (!s.input) throw IngestError(Kind::kCorrupt, "cannot decode image: " + OIIO::geterror());
  if (!s.input->open(path, opened, config)) throw IngestError(Kind::kCorrupt, "cannot decode image: " + s.input->geterror());
  // A pyramidal or multi-page TIFF: its largest page is the image (usually the first; an
  // overview stored first would otherwise be taken for it). Only TIFF's pages are looked at: a
  // WebP's reader, asked for a frame past the last, cannot decode its first one afterwards.
  if (s.info.source_format == "tiff") {
    const auto pixels = [&] {
      return std::uint64_t(std::max(0, s.input->spec().width)) * std::uint64_t(std::max(0, s.input->spec().height));
    };
    std::uint64_t largest = pixels();
    for (int i = 1; s.input->seek_subimage(i, 0); ++i)
      if (pixels() > largest) largest = pixels(), s.subimage = i;
    if (!s.input->seek_subimage(s.subimage, 0)) throw IngestError(Kind::kCorrupt, "cannot decode image: " + s.input->geterror());
    // Looking for a page past the last leaves libtiff's message ("Out of memory"), which
    // check_read() would take for a decoding error.
    s.input->geterror();
  }
  const OIIO::ImageSpec& spec = s.input->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0)
    throw IngestError(Kind::kCorrupt, "image has no usable pixels");
  if (over_limits(std::uint64_t(spec.width), std::uint64_t(spec.height), limits))
    throw IngestError(Kind::kTooLarge, too_large_message(std::uint64_t(spec.width), std::uint64_t(spec.height), limits));
  s.read_channels = std::min(spec.nchannels, 4);
  if (const OIIO::ParamValue* icc = spec.find_attribute("ICCProfile")) {
    try {
      s.icc = IccToSrgb::for_profile(static_cast<const std::uint8_t*>(icc->data()), icc->type().size(), s.read_channels);
    } catch (const std::runtime_error& e) {
      throw IngestError(Kind::kCorrupt, std::string("the image cannot be shown in sRGB: ") + e.what());
    }
  }
  s.info.channels = stored_channels(spec);
  s.info.source_channels = spec.nchannels;
  s.info.source_bits = int(spec.format.size() * 8);
  s.info.source_orientation = spec.get_int_attribute("Orientation", 1);
  if (s.info.source_orientation < 1 || s.info.source_orientation > 8) s.info.source_orientation = 1;
  const bool swaps = s.info.source_orientation >= 5;
  if (s.info.source_orientation != 1)
    check_decode_memory(2 * whole_decode_bytes(std::uint64_t(spec.width), std::uint64_t(spec.height), s.read_channels, 1),
                        limits, "this image must be decoded whole to be turned upright (EXIF orientation " +
                                    std::to_string(s.info.source_orientation) + ")");
  s.source_width = spec.width, s.source_height = spec.height;
  s.info.width = swaps ? spec.height : spec.width;
  s.info.height = swaps ? spec.width : spec.height;
  s.info.levels = pyramid_levels(s.info.width, s.info.height);
  return s;
}

// Rows [y0, y1) of the source's first `channels` channels as 8-bit, packed, read in order. A
// source that is already that (8-bit JPEGs, PNGs, TIFFs with all their channels) is decoded
// straight into `out` by the format's reader: OpenImageIO 2.4's read_scanlines takes its
// converting path even then, allocating a 64 MB buffer per call (mapped afresh, so its pages
// fault in again every 16 rows) and copying the rows out of it — for the 127 MP test image, 529
// such calls moved 380 MB through fresh pages on the decoding thread, the pyramid's critical path
// (tiles/README.md). A tiled source (a tiled or pyramidal TIFF) is read a row of tiles at a time
// into a band the rows are copied from: it has no scanlines, and OpenImageIO 2.4's read_scanlines
// on one divides by zero (SIGFPE). The band is the image's width × one tile's height.
class RowReader {
 public:
  RowReader(OIIO::ImageInput& in, int subimage, int channels) : in_(in), subimage_(subimage), channels_(channels) {}

  bool read(int y0, int y1, std::uint8_t* out) {
    const OIIO::ImageSpec& spec = in_.spec();
    if (spec.tile_width > 0 && spec.tile_height > 0) return read_tiled(y0, y1, out);
    if (spec.format == OIIO::TypeDesc::UINT8 && spec.channelformats.empty() && channels_ == spec.nchannels)
      return in_.read_native_scanlines(subimage_, 0, y0, y1, 0, out);
    return in_.read_scanlines(subimage_, 0, y0, y1, 0, 0, channels_, OIIO::TypeDesc::UINT8, out);
  }

 private:
  bool read_tiled(int y0, int y1, std::uint8_t* out) {
    const OIIO::ImageSpec& spec = in_.spec();
    const std::size_t row_bytes = std::size_t(spec.width) * channels_;
    for (int y = y0; y < y1;) {
      if (y < band_y0_ || y >= band_y1_) {
        band_y0_ = y - (y - spec.y) % spec.tile_height;
        band_y1_ = std::min(band_y0_ + spec.tile_height, spec.y + spec.height);
        band_.resize(row_bytes * std::size_t(band_y1_ - band_y0_));
        if (!in_.read_tiles(subimage_, 0, spec.x, spec.x + spec.width, band_y0_, band_y1_, spec.z, spec.z + 1, 0,
                            channels_, OIIO::TypeDesc::UINT8, band_.data()))
          return false;
      }
      const int n = std::min(y1, band_y1_) - y;
      std::memcpy(out + row_bytes * std::size_t(y - y0), band_.data() + row_bytes * std::size_t(y - band_y0_),
                  row_bytes * std::size_t(n));
      y += n;
    }
    return true;
  }

  OIIO::ImageInput& in_;
  int subimage_, channels_;
  std::vector<std::uint8_t> band_;
  int band_y0_ = 0, band_y1_ = 0;  // the rows band_ holds
};

void check_read(OIIO::ImageInput& in, bool ok) {
  // libjpeg reports a truncated file as a warning and pads it grey; OIIO passes that on as an
  // error message even when the read "succeeds", so both are treated as corrupt input.
  std::string err = in.geterror();
  if (!ok || !err.empty())
    throw IngestError(Kind::kCorrupt, "image data is corrupt or truncated" +
                                          (err.empty() ? std::string() : ": " + err));
}

}  // namespace

std::string level_filename(int k) { return "level_" + std::to_string(k) + ".tif"; }

PyramidInfo build_pyramid(const std::string& path, const std::string& out_dir,
                          const PyramidOptions& options, const SourceLimits& limits,
                          const ProgressFn& progress) {
  OpenSource src = open_source(path, limits, options.threads);
  src.info.compression = choose_compression(options, path, src.info);
  const PyramidInfo& info = src.info;
  const int rc = src.read_channels, ch = info.channels;
  const int sw = src.source_width, sh = src.source_height;

  // Strips given to the pipeline and not yet encoded hold at most one level-0 strip's pixels (or
  // four tiles per thread, for narrow images; 64 MB at most, for very wide ones): the other
  // threads compress a strip while the decoder fills the next. Memory stays that of the strips
  // being filled plus this, and does not grow with the image's height. Half a strip (as with zip
  // tiles, whose compression outweighed decoding 5:1) left JPEG tiles' encoders idle while the
  // decoder, the pyramid's critical path, helped: the 952 MP image's pyramid took 6.5 s with half
  // a strip, 5.8 s with one (1.5: 5.6 s, for 12 MB more at its 31 872 px width; issue 18).
  constexpr std::size_t kMaxInFlightBytes = 64 << 20;
  const std::size_t tile_bytes = std::size_t(options.tile_size) * options.tile_size * ch;
  const std::size_t strip0_bytes = tile_bytes * std::size_t((info.width + options.tile_size - 1) / options.tile_size);
  const std::size_t per_thread = 4 * tile_bytes * std::size_t(std::max(options.threads, 1));
  StripPipeline pipeline(options.threads, std::max(std::min(strip0_bytes, kMaxInFlightBytes), per_thread));
  LevelWriter level0(out_dir, 0, info.width, info.height, ch, options, info.compression, pipeline);

  if (info.source_orientation == 1) {
    // Decoded straight into level 0's strip when the stored layout is the source's (8-bit RGB or
    // RGBA); otherwise through a small buffer, mapped to RGB(A). Small chunks either way.
    const int chunk = 16;
    const bool direct = rc == ch;
    std::vector<std::uint8_t> buf(direct ? 0 : std::size_t(chunk) * sw * rc);
    std::optional<RowReader> reader;
    if (src.input) reader.emplace(*src.input, src.subimage, rc);
    for (int y = 0; y < sh;) {
      const int n = std::min({chunk, sh - y, level0.rows_free()});
      std::uint8_t* rows = level0.free_rows();
      if (src.jpeg2000) src.jpeg2000->read(y, y + n, rc, direct ? rows : buf.data());
      else check_read(*src.input, reader->read(y, y + n, direct ? rows : buf.data()));
      if (src.icc) src.icc->convert(direct ? rows : buf.data(), std::size_t(n) * sw);
      if (!direct)
        for (int r = 0; r < n; ++r)
          to_stored(buf.data() + std::size_t(r) * sw * rc, rc, sw, ch, rows + std::size_t(r) * sw * ch);
      level0.add_rows(n);
      y += n;
      if (progress) progress(0.95 * y / sh);
    }
  } else {
    // A rotation needs whole columns, so the image is decoded whole (8-bit) and reoriented
    // (within the memory limit: open_source). Only OpenImageIO's readers report an orientation.
    OIIO::ImageInput& in = *src.input;
    OIIO::ImageSpec spec8(sw, sh, rc, OIIO::TypeDesc::UINT8);
    OIIO::ImageBuf whole(spec8);
    check_read(in, in.read_image(src.subimage, 0, 0, rc, OIIO::TypeDesc::UINT8, whole.localpixels()));
    if (src.icc) src.icc->convert(static_cast<std::uint8_t*>(whole.localpixels()), std::size_t(sw) * sh);
    whole.specmod().attribute("Orientation", info.source_orientation);
    if (progress) progress(0.3);
    OIIO::ImageBuf upright = OIIO::ImageBufAlgo::reorient(whole);
    if (upright.has_error()) throw IngestError(Kind::kCorrupt, upright.geterror());
    whole.reset();
    std::vector<std::uint8_t> src_row(std::size_t(info.width) * rc);
    for (int y = 0; y < info.height; ++y) {
      upright.get_pixels(OIIO::ROI(0, info.width, y, y + 1, 0, 1, 0, rc), OIIO::TypeDesc::UINT8,
                         src_row.data());
      to_stored(src_row.data(), rc, info.width, ch, level0.free_rows());
      level0.add_rows(1);
      if (progress && y % 256 == 0) progress(0.3 + 0.65 * y / info.height);
    }
  }
  level0.flush();
  pipeline.drain();
  level0.close();
  if (progress) progress(1.0);
  return info;
}

}  // namespace zoomwarp::tiles
