#include "tests/support/images.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>
#include <OpenImageIO/imageio.h>
#include <jxl/decode.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <memory>
#include <stdexcept>

#include "tests/support/server_process.h"

namespace zoomwarp::testing {

namespace {
bool is_jxl(const std::string& bytes) {
  return bytes.rfind("\xFF\x0A", 0) == 0 || bytes.rfind(std::string("\0\0\0\x0CJXL \r\n\x87\n", 12), 0) == 0;
}

// JPEG XL through libjxl's decoder (OpenImageIO 2.4 has no JPEG XL reader): 8-bit, as many
// channels as the image has colour channels plus alpha.
tiles::Raster decode_jxl(const std::string& bytes) {
  std::unique_ptr<JxlDecoder, void (*)(JxlDecoder*)> dec(JxlDecoderCreate(nullptr), JxlDecoderDestroy);
  if (!dec || JxlDecoderSubscribeEvents(dec.get(), JXL_DEC_BASIC_INFO | JXL_DEC_FULL_IMAGE) != JXL_DEC_SUCCESS ||
      JxlDecoderSetInput(dec.get(), reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()) != JXL_DEC_SUCCESS)
    throw std::runtime_error("cannot start the JPEG XL decoder");
  JxlDecoderCloseInput(dec.get());
  tiles::Raster out;
  JxlPixelFormat format{0, JXL_TYPE_UINT8, JXL_NATIVE_ENDIAN, 0};
  while (true) {
    const JxlDecoderStatus status = JxlDecoderProcessInput(dec.get());
    if (status == JXL_DEC_BASIC_INFO) {
      JxlBasicInfo info;
      if (JxlDecoderGetBasicInfo(dec.get(), &info) != JXL_DEC_SUCCESS) throw std::runtime_error("bad JPEG XL header");
      format.num_channels = info.num_color_channels + (info.alpha_bits > 0 ? 1 : 0);
      out = tiles::Raster(int(info.xsize), int(info.ysize), int(format.num_channels));
    } else if (status == JXL_DEC_NEED_IMAGE_OUT_BUFFER) {
      if (JxlDecoderSetImageOutBuffer(dec.get(), &format, out.pixels.data(), out.pixels.size()) != JXL_DEC_SUCCESS)
        throw std::runtime_error("JPEG XL output buffer refused");
    } else if (status == JXL_DEC_FULL_IMAGE) {
      continue;
    } else if (status == JXL_DEC_SUCCESS) {
      return out;
    } else {
      throw std::runtime_error("cannot decode the JPEG XL image");
    }
  }
}

std::string sniff_extension(const std::string& bytes) {
  if (bytes.rfind("\xFF\xD8\xFF", 0) == 0) return ".jpg";
  if (bytes.rfind("\x89PNG", 0) == 0) return ".png";
  if (bytes.size() > 12 && bytes.compare(8, 4, "WEBP") == 0) return ".webp";
  if (bytes.size() > 12 && bytes.compare(4, 8, "ftypavif") == 0) return ".avif";
  throw std::runtime_error("response is not an image (" + std::to_string(bytes.size()) + " bytes)");
}
}  // namespace

tiles::Raster decode_image(const std::string& bytes) {
  if (is_jxl(bytes)) return decode_jxl(bytes);
  TempDir dir;
  const std::string path = dir.path() + "/image" + sniff_extension(bytes);
  std::ofstream(path, std::ios::binary).write(bytes.data(), std::streamsize(bytes.size()));
  return load_image(path);
}

tiles::Raster load_image(const std::string& path) {
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  OIIO::ImageBuf buf(path, 0, 0, nullptr, &config);
  if (!buf.read(0, 0, true, OIIO::TypeDesc::UINT8)) throw std::runtime_error("cannot read " + path + ": " + buf.geterror());
  OIIO::ImageBuf upright = OIIO::ImageBufAlgo::reorient(buf);
  const auto& spec = upright.spec();
  tiles::Raster r(spec.width, spec.height, spec.nchannels);
  upright.get_pixels(OIIO::ROI(0, spec.width, 0, spec.height, 0, 1, 0, spec.nchannels), OIIO::TypeDesc::UINT8,
                     r.pixels.data());
  return r;
}

tiles::Raster crop(const tiles::Raster& in, tiles::Rect rect) {
  tiles::Raster out(int(rect.w), int(rect.h), in.channels);
  for (int y = 0; y < out.height; ++y)
    std::copy_n(in.row(int(rect.y) + y) + rect.x * in.channels, out.row_bytes(), out.row(y));
  return out;
}

tiles::Raster resize(const tiles::Raster& in, int w, int h) {
  OIIO::ImageSpec spec(in.width, in.height, in.channels, OIIO::TypeDesc::UINT8);
  spec.alpha_channel = -1;
  OIIO::ImageBuf src(spec, const_cast<std::uint8_t*>(in.pixels.data()));
  OIIO::ImageSpec out_spec(w, h, in.channels, OIIO::TypeDesc::UINT8);
  out_spec.alpha_channel = -1;
  tiles::Raster out(w, h, in.channels);
  OIIO::ImageBuf dst(out_spec, out.pixels.data());
  OIIO::ImageBufAlgo::resize(dst, src);
  return out;
}

tiles::Raster take_channels(const tiles::Raster& in, int channels) {
  tiles::Raster out(in.width, in.height, channels);
  const std::size_t n = std::size_t(in.width) * in.height;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < channels; ++c) out.pixels[i * channels + c] = in.pixels[i * in.channels + std::min(c, in.channels - 1)];
  return out;
}

double psnr(const tiles::Raster& a, const tiles::Raster& b) {
  if (a.width != b.width || a.height != b.height || a.channels != b.channels)
    throw std::runtime_error("psnr: sizes differ (" + std::to_string(a.width) + "x" + std::to_string(a.height) + "x" +
                             std::to_string(a.channels) + " vs " + std::to_string(b.width) + "x" +
                             std::to_string(b.height) + "x" + std::to_string(b.channels) + ")");
  double se = 0;
  for (std::size_t i = 0; i < a.pixels.size(); ++i) {
    const double d = double(a.pixels[i]) - double(b.pixels[i]);
    se += d * d;
  }
  if (se == 0) return std::numeric_limits<double>::infinity();
  const double mse = se / double(a.pixels.size());
  return 10.0 * std::log10(255.0 * 255.0 / mse);
}

void write_image(const std::string& path, const tiles::Raster& r, int bits, int orientation, int quality) {
  OIIO::ImageSpec spec8(r.width, r.height, r.channels, OIIO::TypeDesc::UINT8);
  OIIO::ImageBuf buf(spec8, const_cast<std::uint8_t*>(r.pixels.data()));
  OIIO::ImageBuf out = bits == 16 ? buf.copy(OIIO::TypeDesc::UINT16) : buf.copy(OIIO::TypeDesc::UINT8);
  if (orientation != 1) out.specmod().attribute("Orientation", orientation);
  if (quality > 0) out.specmod().attribute("CompressionQuality", quality);
  if (r.channels == 4 || r.channels == 2) out.specmod().attribute("oiio:UnassociatedAlpha", 1);
  if (!out.write(path)) throw std::runtime_error("cannot write " + path + ": " + out.geterror());
}

tiles::Raster test_pattern(int w, int h, int channels) {
  tiles::Raster r(w, h, channels);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = r.row(y) + std::size_t(x) * channels;
      const bool grid = (x % 64) < 2 || (y % 64) < 2;
      const std::uint8_t v[4] = {std::uint8_t(grid ? 0 : 255 * x / std::max(1, w - 1)),
                                 std::uint8_t(grid ? 0 : 255 * y / std::max(1, h - 1)),
                                 std::uint8_t(((x / 16) + (y / 16)) % 2 ? 200 : 40),
                                 std::uint8_t(x < w / 2 ? 255 : 96)};
      for (int c = 0; c < channels; ++c) p[c] = channels <= 2 && c == 0 ? std::uint8_t((v[0] + v[1]) / 2) : v[channels == 2 && c == 1 ? 3 : c];
    }
  return r;
}

}  // namespace zoomwarp::testing
