#include "tiles/jpeg2000_rows.h"

#include <openjpeg.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <fstream>

#include "tiles/ingest_error.h"

namespace zoomwarp::tiles {

namespace {

using Kind = IngestError::Kind;

// Bytes OpenJPEG hands a tile's sample over in (opj_decode_tile_data, as opj_write_tile takes them).
int sample_bytes(int prec) { return prec <= 8 ? 1 : prec <= 16 ? 2 : 4; }

std::int32_t sample_at(const std::uint8_t* p, int bytes, bool sgnd) {
  switch (bytes) {
    case 1: return sgnd ? std::int32_t(std::int8_t(*p)) : std::int32_t(*p);
    case 2: {
      std::uint16_t v;
      std::memcpy(&v, p, 2);
      return sgnd ? std::int32_t(std::int16_t(v)) : std::int32_t(v);
    }
    default: {
      std::int32_t v;
      std::memcpy(&v, p, 4);
      return v;
    }
  }
}

// `n` samples of `bytes` each at `in` as 8-bit into every `stride`-th byte of `out`: signed ones
// offset by half their range, scaled from `prec` bits by 255 / (2^prec − 1) and rounded, as
// OpenImageIO's reader converts them.
void to_8bit(const std::uint8_t* in, int bytes, bool sgnd, int prec, int n, std::uint8_t* out, int stride) {
  if (bytes == 1 && !sgnd && prec == 8) {
    for (int i = 0; i < n; ++i) out[std::size_t(i) * stride] = in[i];
    return;
  }
  const std::int64_t max = (std::int64_t(1) << prec) - 1, offset = sgnd ? std::int64_t(1) << (prec - 1) : 0;
  for (int i = 0; i < n; ++i) {
    const std::int64_t v = std::clamp<std::int64_t>(sample_at(in + std::size_t(i) * bytes, bytes, sgnd) + offset, 0, max);
    out[std::size_t(i) * stride] = std::uint8_t((v * 255 + max / 2) / max);
  }
}

// Whether the JP2's header box holds a palette ('pclr') or channel definitions ('cdef'), which
// OpenJPEG applies only when it decodes a whole image (opj_decode), not tile by tile: such files
// are read by OpenImageIO. ISO 15444-1 §I.5.3: 'jp2h' is a superbox of 'ihdr', 'colr', 'pclr',
// 'cmap', 'cdef', 'res '. "" when it holds neither.
std::string header_box_problem(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  std::vector<char> head(64 << 10);
  f.read(head.data(), std::streamsize(head.size()));
  const std::size_t n = std::size_t(f.gcount());
  auto u32 = [&](std::size_t at) {
    return std::uint32_t(std::uint8_t(head[at])) << 24 | std::uint32_t(std::uint8_t(head[at + 1])) << 16 |
           std::uint32_t(std::uint8_t(head[at + 2])) << 8 | std::uint32_t(std::uint8_t(head[at + 3]));
  };
  for (std::size_t at = 0; at + 8 <= n;) {
    const std::uint32_t size = u32(at);
    const std::string type(&head[at + 4], 4);
    if (type == "jp2h") {
      const std::size_t end = std::min<std::size_t>(n, at + size);
      for (std::size_t c = at + 8; c + 8 <= end;) {
        const std::uint32_t csize = u32(c);
        const std::string ctype(&head[c + 4], 4);
        if (ctype == "pclr") return "it has a palette";
        if (ctype == "cdef") return "it defines its channels' order (cdef)";
        if (csize < 8) break;
        c += csize;
      }
      return "";
    }
    if (type == "jp2c" || size < 8) return "";
    at += size;
  }
  return "";
}

}  // namespace

struct Jpeg2000Rows::Codec {
  opj_codec_t* codec = nullptr;
  opj_stream_t* stream = nullptr;
  opj_image_t* image = nullptr;
  std::string error;  // OpenJPEG's last error message

  ~Codec() {
    if (image) opj_image_destroy(image);
    if (stream) opj_stream_destroy(stream);
    if (codec) opj_destroy_codec(codec);
  }

  [[noreturn]] void fail(const std::string& what) const {
    throw IngestError(Kind::kCorrupt, "cannot decode the JPEG 2000 image: " + what + (error.empty() ? "" : ": " + error));
  }
};

Jpeg2000Rows::Jpeg2000Rows(const std::string& path, const std::string& format, int threads,
                           std::uint64_t untiled_band_bytes)
    : codec_(std::make_unique<Codec>()) {
  Codec& c = *codec_;
  c.stream = opj_stream_create_default_file_stream(path.c_str(), OPJ_TRUE);
  if (!c.stream) c.fail("the file cannot be read");
  c.codec = opj_create_decompress(format == "jp2" ? OPJ_CODEC_JP2 : OPJ_CODEC_J2K);
  if (!c.codec) c.fail("no decoder");
  opj_set_error_handler(
      c.codec, [](const char* msg, void* data) {
        std::string& error = *static_cast<std::string*>(data);
        error = msg;
        while (!error.empty() && error.back() == '\n') error.pop_back();
      },
      &c.error);
  opj_set_warning_handler(c.codec, [](const char*, void*) {}, nullptr);
  opj_set_info_handler(c.codec, [](const char*, void*) {}, nullptr);
  opj_dparameters_t params;
  opj_set_default_decoder_parameters(&params);
  if (!opj_setup_decoder(c.codec, &params)) c.fail("the decoder cannot be set up");
  if (threads > 1) opj_codec_set_threads(c.codec, threads);
  if (!opj_read_header(c.stream, c.codec, &c.image) || !c.image) c.fail("its header cannot be read");

  const opj_image_t& im = *c.image;
  x0_ = int(im.x0), y0_ = int(im.y0);
  width_ = int(im.x1 - im.x0), height_ = int(im.y1 - im.y0);
  components_ = int(im.numcomps);
  if (width_ <= 0 || height_ <= 0 || components_ <= 0) c.fail("the image is empty");
  if (im.icc_profile_buf && im.icc_profile_len > 0) icc_.assign(im.icc_profile_buf, im.icc_profile_buf + im.icc_profile_len);

  opj_codestream_info_v2_t* info = opj_get_cstr_info(c.codec);
  if (!info) c.fail("its tiling cannot be read");
  tile_w_ = int(info->tdx), tile_h_ = int(info->tdy), tile_x0_ = int(info->tx0), tile_y0_ = int(info->ty0);
  tiles_x_ = int(info->tw), tiles_y_ = int(info->th);
  opj_destroy_cstr_info(&info);
  if (tile_w_ <= 0 || tile_h_ <= 0 || tiles_x_ <= 0 || tiles_y_ <= 0) c.fail("its tiling is impossible");

  for (int k = 0; k < components_; ++k) {
    const opj_image_comp_t& comp = im.comps[k];
    bits_ = std::max(bits_, int(comp.prec));
    if (comp.dx != 1 || comp.dy != 1) why_not_ = "its components are subsampled";
    else if (comp.prec < 1 || comp.prec > 16) why_not_ = "a component has " + std::to_string(comp.prec) + " bits";
  }
  if (why_not_.empty() && im.color_space != OPJ_CLRSPC_UNKNOWN && im.color_space != OPJ_CLRSPC_UNSPECIFIED &&
      im.color_space != OPJ_CLRSPC_SRGB && im.color_space != OPJ_CLRSPC_GRAY)
    why_not_ = "its colour space is not sRGB or grey";
  if (why_not_.empty() && components_ > 4) why_not_ = "it has more than 4 components";
  if (why_not_.empty() && format == "jp2") why_not_ = header_box_problem(path);
  if (!tiled()) {
    std::error_code ec;
    codestream_bytes_ = std::filesystem::file_size(path, ec);
    const std::uint64_t row_bytes = std::uint64_t(width_) * components_ * 4;
    band_rows_ = int(std::clamp<std::uint64_t>(untiled_band_bytes / row_bytes, 1, std::uint64_t(height_)));
  }
}

Jpeg2000Rows::~Jpeg2000Rows() = default;

int Jpeg2000Rows::band_rows() const { return tiled() ? std::min(tile_h_, height_) : band_rows_; }

std::uint64_t Jpeg2000Rows::peak_bytes() const {
  const std::uint64_t px = std::uint64_t(components_);
  if (!tiled()) {
    // OpenJPEG holds the one tile's codestream whole, and over a band its 32-bit samples, its
    // wavelet and code-block buffers: measured 260 MB above the process's own for 32 MB of samples
    // a band (a 100 MP lossy JP2), so 8 times the band's samples.
    const std::uint64_t band = std::uint64_t(band_rows_) * width_ * px;
    return band * 4 * 8 + codestream_bytes_;
  }
  // Two bands (the one handed out, the next being assembled), one tile as handed over, and
  // OpenJPEG's tile: 32-bit samples and as much again for its wavelet and code-blocks.
  const std::uint64_t band = std::uint64_t(std::min(tile_h_, height_)) * width_ * px;
  const std::uint64_t tile = std::uint64_t(std::min(tile_w_, width_)) * std::min(tile_h_, height_) * px;
  return 2 * band + tile * (sample_bytes(bits_) + 4 + 4);
}

void Jpeg2000Rows::read(int y0, int y1, int channels, std::uint8_t* out) {
  const std::size_t row_out = std::size_t(width_) * channels;
  for (int y = y0; y < y1;) {
    while (y >= band_y1_) next_band();
    const int n = std::min(y1, band_y1_) - y;
    for (int r = 0; r < n; ++r) {
      const std::uint8_t* src = band_.data() + std::size_t(y + r - band_y0_) * width_ * components_;
      std::uint8_t* dst = out + std::size_t(y + r - y0) * row_out;
      if (channels == components_) {
        std::memcpy(dst, src, row_out);
      } else {
        for (int x = 0; x < width_; ++x)
          std::memcpy(dst + std::size_t(x) * channels, src + std::size_t(x) * components_, std::size_t(channels));
      }
    }
    y += n;
  }
}

void Jpeg2000Rows::next_band() {
  if (band_y1_ >= height_) codec_->fail("rows past the image's end were asked for");
  if (tiled()) decode_tiled_band();
  else decode_untiled_band();
}

void Jpeg2000Rows::decode_tiled_band() {
  Codec& c = *codec_;
  // Tile row j covers rows [tile_y0 + j·tile_h, tile_y0 + (j+1)·tile_h) of the reference grid,
  // clipped to the image area; so does every tile OpenJPEG hands over.
  auto rows_of = [&](int row, int& top, int& bottom) {
    top = std::max(y0_, tile_y0_ + row * tile_h_) - y0_;
    bottom = std::min(y0_ + height_, tile_y0_ + (row + 1) * tile_h_) - y0_;
  };
  const int row = next_band_row_;
  int top, bottom;
  rows_of(row, top, bottom);
  const std::size_t pixel = std::size_t(components_);
  for (;;) {
    PendingBand& want = pending_[row];
    if (want.tiles_done == tiles_x_) break;
    OPJ_UINT32 index = 0, size = 0, ncomps = 0;
    OPJ_INT32 tx0 = 0, ty0 = 0, tx1 = 0, ty1 = 0;
    OPJ_BOOL go_on = OPJ_TRUE;
    if (!opj_read_tile_header(c.codec, c.stream, &index, &size, &tx0, &ty0, &tx1, &ty1, &ncomps, &go_on))
      c.fail("a tile's header cannot be read");
    if (!go_on) c.fail("the codestream ends before tile row " + std::to_string(row + 1) + " of " + std::to_string(tiles_y_));
    if (int(ncomps) != components_ || tx0 < x0_ || ty0 < y0_ || tx1 > x0_ + width_ || ty1 > y0_ + height_ || tx1 <= tx0 ||
        ty1 <= ty0)
      c.fail("a tile lies outside the image");
    tile_data_.resize(size);
    if (!opj_decode_tile_data(c.codec, index, tile_data_.data(), size, c.stream)) c.fail("a tile cannot be decoded");
    const int tile_row = int(index) / tiles_x_;
    if (tile_row < row) c.fail("a tile came twice");
    int band_top, band_bottom;
    rows_of(tile_row, band_top, band_bottom);
    PendingBand& band = pending_[tile_row];
    if (band.pixels.empty()) band.pixels.resize(std::size_t(band_bottom - band_top) * width_ * pixel);
    // The tile's components one after another (opj_decode_tile_data), each tw × th samples.
    const int tw = tx1 - tx0, th = ty1 - ty0;
    std::size_t at = 0;
    for (int k = 0; k < components_; ++k) {
      const opj_image_comp_t& comp = c.image->comps[k];
      const int bytes = sample_bytes(int(comp.prec));
      for (int r = 0; r < th; ++r) {
        const int y = ty0 - y0_ + r - band_top;
        std::uint8_t* dst = band.pixels.data() + (std::size_t(y) * width_ + (tx0 - x0_)) * pixel + k;
        to_8bit(tile_data_.data() + at, bytes, comp.sgnd != 0, int(comp.prec), tw, dst, components_);
        at += std::size_t(tw) * bytes;
      }
    }
    ++band.tiles_done;
  }
  band_ = std::move(pending_[row].pixels);
  pending_.erase(row);
  band_y0_ = top, band_y1_ = bottom;
  ++next_band_row_;
}

void Jpeg2000Rows::decode_untiled_band() {
  Codec& c = *codec_;
  const int top = band_y1_, bottom = std::min(height_, top + band_rows_);
  if (!opj_set_decode_area(c.codec, c.image, x0_, y0_ + top, x0_ + width_, y0_ + bottom))
    c.fail("rows " + std::to_string(top) + "-" + std::to_string(bottom) + " cannot be asked for");
  if (!opj_decode(c.codec, c.stream, c.image)) c.fail("rows " + std::to_string(top) + "-" + std::to_string(bottom) + " cannot be decoded");
  band_.resize(std::size_t(bottom - top) * width_ * components_);
  for (int k = 0; k < components_; ++k) {
    const opj_image_comp_t& comp = c.image->comps[k];
    if (!comp.data || int(comp.w) != width_ || int(comp.h) != bottom - top) c.fail("a band came back of another size");
    for (int r = 0; r < bottom - top; ++r)
      to_8bit(reinterpret_cast<const std::uint8_t*>(comp.data + std::size_t(r) * width_), 4, comp.sgnd != 0, int(comp.prec),
              width_, band_.data() + std::size_t(r) * width_ * components_ + k, components_);
  }
  band_y0_ = top, band_y1_ = bottom;
}

}  // namespace zoomwarp::tiles
