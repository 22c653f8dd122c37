#include "tiles/pyramid_builder.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>

#include <memory>
#include <vector>

#include "tiles/manifest.h"
#include "tiles/source_format.h"

namespace zoomwarp::tiles {

namespace {

using Kind = IngestError::Kind;

// Averages two rows (b may be a, for the last row of an odd height) into one row of half the
// width, rounded up; an odd last column averages with itself. With alpha, colours are weighted by
// alpha so that invisible pixels do not bleed their colour into the coarser levels.
void halve_rows(const std::uint8_t* a, const std::uint8_t* b, int w, int ch, std::uint8_t* out) {
  const int half = (w + 1) / 2;
  for (int x = 0; x < half; ++x) {
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

// One level being written: rows are gathered into a strip one tile high, each full strip is
// written as a row of tiles, and pairs of rows are halved into the next coarser level.
class LevelWriter {
 public:
  LevelWriter(const std::string& dir, int level, int w, int h, int ch, const PyramidOptions& opt)
      : w_(w), h_(h), ch_(ch), tile_(opt.tile_size) {
    const std::string path = dir + "/" + level_filename(level);
    OIIO::ImageSpec spec(w, h, ch, OIIO::TypeDesc::UINT8);
    spec.tile_width = spec.tile_height = tile_;
    spec.tile_depth = 1;
    spec.alpha_channel = -1;  // store straight values; no reader may premultiply them
    spec.attribute("compression", opt.compression);
    spec.attribute("Software", "zoomwarp");
    out_ = OIIO::ImageOutput::create(path);
    if (!out_ || !out_->open(path, spec))
      throw IngestError(Kind::kIo, "cannot create " + path + ": " + OIIO::geterror());
    strip_.resize(std::size_t(tile_) * w_ * ch_);
    tile_buf_.resize(std::size_t(tile_) * tile_ * ch_);
    if (w > 1 || h > 1) {
      next_ = std::make_unique<LevelWriter>(dir, level + 1, (w + 1) / 2, (h + 1) / 2, ch, opt);
      pending_.resize(std::size_t(w_) * ch_);
      half_.resize(std::size_t((w_ + 1) / 2) * ch_);
    }
  }

  void push_row(const std::uint8_t* row) {
    std::copy_n(row, std::size_t(w_) * ch_, strip_.data() + std::size_t(strip_rows_) * w_ * ch_);
    if (++strip_rows_ == tile_) flush_strip();
    if (!next_) return;
    if (has_pending_) {
      halve_rows(pending_.data(), row, w_, ch_, half_.data());
      next_->push_row(half_.data());
      has_pending_ = false;
    } else {
      std::copy_n(row, pending_.size(), pending_.data());
      has_pending_ = true;
    }
  }

  void finish() {
    if (strip_rows_ > 0) flush_strip();
    if (next_) {
      if (has_pending_) {
        halve_rows(pending_.data(), pending_.data(), w_, ch_, half_.data());
        next_->push_row(half_.data());
      }
      next_->finish();
    }
    if (!out_->close()) throw IngestError(Kind::kIo, "cannot finish a level: " + out_->geterror());
  }

 private:
  // Writes the strip one whole tile at a time. Edge tiles are padded by repeating the last column
  // and row: the padding then compresses to almost nothing and holds no stale memory.
  void flush_strip() {
    const std::size_t px = std::size_t(ch_);
    for (int x0 = 0; x0 < w_; x0 += tile_) {
      const int cols = std::min(tile_, w_ - x0);
      for (int r = 0; r < tile_; ++r) {
        const std::uint8_t* src = strip_.data() + (std::size_t(std::min(r, strip_rows_ - 1)) * w_ + x0) * px;
        std::uint8_t* dst = tile_buf_.data() + std::size_t(r) * tile_ * px;
        std::copy_n(src, cols * px, dst);
        for (int c = cols; c < tile_; ++c) std::copy_n(src + (cols - 1) * px, px, dst + c * px);
      }
      if (!out_->write_tile(x0, strip_y_, 0, OIIO::TypeDesc::UINT8, tile_buf_.data()))
        throw IngestError(Kind::kIo, "cannot write tiles: " + out_->geterror());
    }
    strip_y_ += strip_rows_;
    strip_rows_ = 0;
  }

  int w_, h_, ch_, tile_;
  std::unique_ptr<OIIO::ImageOutput> out_;
  std::vector<std::uint8_t> strip_, tile_buf_;
  int strip_rows_ = 0, strip_y_ = 0;
  std::vector<std::uint8_t> pending_, half_;
  bool has_pending_ = false;
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

struct OpenSource {
  std::unique_ptr<OIIO::ImageInput> input;
  PyramidInfo info;
  int read_channels = 3;  // source channels we read (≤ 4)
};

OpenSource open_source(const std::string& path, const SourceLimits& limits) {
  OpenSource s;
  s.info.source_format = sniff_image_file(path);
  if (s.info.source_format.empty())
    throw IngestError(Kind::kUnsupportedFormat,
                      "unsupported image format (JPEG, PNG, TIFF and WebP are accepted)");
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);  // keep alpha straight, as the file has it
  s.input = OIIO::ImageInput::open(path, &config);
  if (!s.input) throw IngestError(Kind::kCorrupt, "cannot decode image: " + OIIO::geterror());
  const OIIO::ImageSpec& spec = s.input->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.depth != 1 || spec.nchannels <= 0)
    throw IngestError(Kind::kCorrupt, "image has no usable pixels");
  if (spec.width > limits.max_dimension || spec.height > limits.max_dimension ||
      std::uint64_t(spec.width) * std::uint64_t(spec.height) > limits.max_pixels)
    throw IngestError(Kind::kTooLarge, "image is " + std::to_string(spec.width) + "x" +
                                           std::to_string(spec.height) +
                                           " pixels, over the limit of " +
                                           std::to_string(limits.max_pixels) + " pixels");
  s.read_channels = std::min(spec.nchannels, 4);
  s.info.channels = stored_channels(spec);
  s.info.source_channels = spec.nchannels;
  s.info.source_bits = int(spec.format.size() * 8);
  s.info.source_orientation = spec.get_int_attribute("Orientation", 1);
  if (s.info.source_orientation < 1 || s.info.source_orientation > 8) s.info.source_orientation = 1;
  const bool swaps = s.info.source_orientation >= 5;
  s.info.width = swaps ? spec.height : spec.width;
  s.info.height = swaps ? spec.width : spec.height;
  s.info.levels = pyramid_levels(s.info.width, s.info.height);
  return s;
}

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

PyramidInfo probe_source(const std::string& path, const SourceLimits& limits) {
  return open_source(path, limits).info;
}

PyramidInfo build_pyramid(const std::string& path, const std::string& out_dir,
                          const PyramidOptions& options, const SourceLimits& limits,
                          const ProgressFn& progress) {
  OpenSource src = open_source(path, limits);
  OIIO::ImageInput& in = *src.input;
  const PyramidInfo& info = src.info;
  const int rc = src.read_channels, ch = info.channels;
  const int sw = in.spec().width, sh = in.spec().height;

  LevelWriter level0(out_dir, 0, info.width, info.height, ch, options);
  std::vector<std::uint8_t> row(std::size_t(info.width) * ch);

  if (info.source_orientation == 1) {
    // Small chunks: OpenImageIO allocates conversion buffers proportional to the chunk.
    const int strip = 16;
    std::vector<std::uint8_t> buf(std::size_t(strip) * sw * rc);
    for (int y = 0; y < sh; y += strip) {
      const int n = std::min(strip, sh - y);
      check_read(in, in.read_scanlines(0, 0, y, y + n, 0, 0, rc, OIIO::TypeDesc::UINT8, buf.data()));
      for (int r = 0; r < n; ++r) {
        to_stored(buf.data() + std::size_t(r) * sw * rc, rc, sw, ch, row.data());
        level0.push_row(row.data());
      }
      if (progress) progress(0.95 * (y + n) / sh);
    }
  } else {
    // A rotation needs whole columns, so the image is decoded whole (8-bit) and reoriented.
    OIIO::ImageSpec spec8(sw, sh, rc, OIIO::TypeDesc::UINT8);
    OIIO::ImageBuf whole(spec8);
    check_read(in, in.read_image(0, 0, 0, rc, OIIO::TypeDesc::UINT8, whole.localpixels()));
    whole.specmod().attribute("Orientation", info.source_orientation);
    if (progress) progress(0.3);
    OIIO::ImageBuf upright = OIIO::ImageBufAlgo::reorient(whole);
    if (upright.has_error()) throw IngestError(Kind::kCorrupt, upright.geterror());
    whole.reset();
    std::vector<std::uint8_t> src_row(std::size_t(info.width) * rc);
    for (int y = 0; y < info.height; ++y) {
      upright.get_pixels(OIIO::ROI(0, info.width, y, y + 1, 0, 1, 0, rc), OIIO::TypeDesc::UINT8,
                         src_row.data());
      to_stored(src_row.data(), rc, info.width, ch, row.data());
      level0.push_row(row.data());
      if (progress && y % 256 == 0) progress(0.3 + 0.65 * y / info.height);
    }
  }
  level0.finish();
  if (progress) progress(1.0);
  return info;
}

}  // namespace zoomwarp::tiles
