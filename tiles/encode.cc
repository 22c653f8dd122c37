#include "tiles/encode.h"

#include <avif/avif.h>
#include <jxl/encode.h>
#include <png.h>
#include <turbojpeg.h>
#include <webp/encode.h>

#include <algorithm>
#include <cmath>
#include <csetjmp>
#include <memory>
#include <stdexcept>
#include <vector>

#include "tiles/raster_ops.h"

namespace zoomwarp::tiles {

namespace {

std::string encode_jpeg(const Raster& in, int quality) {
  // Alpha is composited away first; an opaque raster (every view) is compressed as it is, not
  // copied.
  const bool alpha = in.channels == 2 || in.channels == 4;
  const Raster composited = alpha ? flatten_alpha(in) : Raster();
  const Raster& flat = alpha ? composited : in;
  // A compressor per thread: creating one costs more than compressing a small tile.
  thread_local std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitCompress(), tjDestroy);
  if (!tj) throw std::runtime_error("cannot start the JPEG encoder");
  const bool grey = flat.channels == 1;
  unsigned char* buf = nullptr;
  unsigned long size = 0;
  if (tjCompress2(tj.get(), flat.pixels.data(), flat.width, 0, flat.height,
                  grey ? TJPF_GRAY : TJPF_RGB, &buf, &size, grey ? TJSAMP_GRAY : TJSAMP_420,
                  std::clamp(quality, 1, 100), TJFLAG_FASTDCT) != 0) {
    tjFree(buf);
    throw std::runtime_error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(tj.get()));
  }
  std::string out(reinterpret_cast<char*>(buf), size);
  tjFree(buf);
  return out;
}

void png_append(png_structp png, png_bytep data, png_size_t n) {
  static_cast<std::string*>(png_get_io_ptr(png))->append(reinterpret_cast<char*>(data), n);
}

std::string encode_png(const Raster& in, int level) {
  static constexpr int kColorType[] = {0, PNG_COLOR_TYPE_GRAY, PNG_COLOR_TYPE_GRAY_ALPHA,
                                       PNG_COLOR_TYPE_RGB, PNG_COLOR_TYPE_RGB_ALPHA};
  std::string out;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
  png_infop info = png ? png_create_info_struct(png) : nullptr;
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    throw std::runtime_error("cannot start the PNG encoder");
  }
  std::vector<png_const_bytep> rows(std::size_t(in.height));
  for (int y = 0; y < in.height; ++y) rows[std::size_t(y)] = in.row(y);
  if (setjmp(png_jmpbuf(png))) {  // libpng reports errors by longjmp
    png_destroy_write_struct(&png, &info);
    throw std::runtime_error("PNG encoding failed");
  }
  png_set_write_fn(png, &out, png_append, nullptr);
  png_set_compression_level(png, std::clamp(level, 0, 9));
  png_set_IHDR(png, info, png_uint_32(in.width), png_uint_32(in.height), 8,
               kColorType[in.channels], PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  png_write_rows(png, const_cast<png_bytepp>(rows.data()), png_uint_32(in.height));
  png_write_end(png, nullptr);
  png_destroy_write_struct(&png, &info);
  return out;
}

// Grey and grey + alpha expanded to RGB(A), for the encoders that have no grey modes (WebP,
// AVIF's RGB path); RGB(A) as it is, not copied.
struct Colour {
  Raster expanded;
  const Raster* image;
};
Colour in_colour(const Raster& in) {
  Colour c{{}, &in};
  if (in.channels > 2) return c;
  c.expanded = Raster(in.width, in.height, in.channels + 2);
  const std::size_t n = std::size_t(in.width) * in.height;
  for (std::size_t i = 0; i < n; ++i) {
    std::uint8_t* o = c.expanded.pixels.data() + i * c.expanded.channels;
    const std::uint8_t* p = in.pixels.data() + i * in.channels;
    o[0] = o[1] = o[2] = p[0];
    if (in.channels == 2) o[3] = p[1];
  }
  c.image = &c.expanded;
  return c;
}

std::string encode_webp(const Raster& in, int quality) {
  if (in.width > kWebpMaxDimension || in.height > kWebpMaxDimension)
    throw std::invalid_argument("WebP images are at most 16383 pixels wide and high");
  const Colour colour = in_colour(in);
  const Raster* src = colour.image;
  std::uint8_t* buf = nullptr;
  const int stride = int(src->row_bytes());
  const float q = float(std::clamp(quality, 1, 100));
  const std::size_t size =
      src->channels == 4 ? WebPEncodeRGBA(src->pixels.data(), src->width, src->height, stride, q, &buf)
                         : WebPEncodeRGB(src->pixels.data(), src->width, src->height, stride, q, &buf);
  if (size == 0) {
    WebPFree(buf);
    throw std::runtime_error("WebP encoding failed");
  }
  std::string out(reinterpret_cast<char*>(buf), size);
  WebPFree(buf);
  return out;
}

// AVIF through libavif and its AV1 encoder (libaom in Debian's libavif), 8-bit 4:2:0, full
// range, one thread (the server runs requests side by side). quality 1…100 maps to AV1's
// quantizer 0…63 as avifenc 1.0's --quality does, (100 − q)·63/100; alpha, if any, is lossless.
std::string encode_avif(const Raster& in, int quality, int speed) {
  if (in.width > kAvifMaxDimension || in.height > kAvifMaxDimension)
    throw std::invalid_argument("AVIF images are served at most 16384 pixels wide and high");
  const Colour colour = in_colour(in);
  const Raster* src = colour.image;
  std::unique_ptr<avifImage, void (*)(avifImage*)> image(
      avifImageCreate(std::uint32_t(src->width), std::uint32_t(src->height), 8, AVIF_PIXEL_FORMAT_YUV420), avifImageDestroy);
  if (!image) throw std::runtime_error("cannot start the AVIF encoder");
  image->yuvRange = AVIF_RANGE_FULL;
  avifRGBImage rgb;
  avifRGBImageSetDefaults(&rgb, image.get());
  rgb.format = src->channels == 4 ? AVIF_RGB_FORMAT_RGBA : AVIF_RGB_FORMAT_RGB;
  rgb.pixels = const_cast<std::uint8_t*>(src->pixels.data());
  rgb.rowBytes = std::uint32_t(src->row_bytes());
  if (avifImageRGBToYUV(image.get(), &rgb) != AVIF_RESULT_OK) throw std::runtime_error("AVIF colour conversion failed");
  std::unique_ptr<avifEncoder, void (*)(avifEncoder*)> encoder(avifEncoderCreate(), avifEncoderDestroy);
  if (!encoder) throw std::runtime_error("cannot start the AVIF encoder");
  encoder->maxThreads = 1;
  encoder->speed = std::clamp(speed, AVIF_SPEED_SLOWEST, AVIF_SPEED_FASTEST);
  encoder->minQuantizer = encoder->maxQuantizer = ((100 - std::clamp(quality, 1, 100)) * 63 + 50) / 100;
  encoder->minQuantizerAlpha = encoder->maxQuantizerAlpha = AVIF_QUANTIZER_LOSSLESS;
  avifRWData out = AVIF_DATA_EMPTY;
  const avifResult result = avifEncoderWrite(encoder.get(), image.get(), &out);
  if (result != AVIF_RESULT_OK) {
    avifRWDataFree(&out);
    throw std::runtime_error(std::string("AVIF encoding failed: ") + avifResultToString(result));
  }
  std::string bytes(reinterpret_cast<const char*>(out.data), out.size);
  avifRWDataFree(&out);
  return bytes;
}

// libjxl 0.7's cjxl maps its --quality to a Butteraugli distance this way (cjxl_main.cc):
// 100 is mathematically lossless there; here it is distance 0.1, visually lossless.
float jxl_distance(int quality) {
  const int q = std::clamp(quality, 1, 100);
  return q >= 30 ? 0.1f + float(100 - q) * 0.09f : 6.4f + float(std::pow(2.5, (30 - q) / 5.0)) / 6.25f;
}

// JPEG XL through libjxl (VarDCT, sRGB, grey kept grey), on the calling thread only (the server
// runs requests side by side); alpha, if any, at the same distance.
std::string encode_jxl(const Raster& in, int quality, int effort) {
  if (in.width > kJxlMaxDimension || in.height > kJxlMaxDimension)
    throw std::invalid_argument("JPEG XL images are served at most 16384 pixels wide and high");
  std::unique_ptr<JxlEncoder, void (*)(JxlEncoder*)> enc(JxlEncoderCreate(nullptr), JxlEncoderDestroy);
  if (!enc) throw std::runtime_error("cannot start the JPEG XL encoder");
  const bool grey = in.channels <= 2, alpha = in.channels == 2 || in.channels == 4;
  JxlBasicInfo info;
  JxlEncoderInitBasicInfo(&info);
  info.xsize = std::uint32_t(in.width);
  info.ysize = std::uint32_t(in.height);
  info.bits_per_sample = 8;
  info.num_color_channels = grey ? 1 : 3;
  info.num_extra_channels = alpha ? 1 : 0;
  info.alpha_bits = alpha ? 8 : 0;
  info.uses_original_profile = JXL_FALSE;  // lossy: XYB
  JxlColorEncoding colour;
  JxlColorEncodingSetToSRGB(&colour, grey ? JXL_TRUE : JXL_FALSE);
  JxlEncoderFrameSettings* frame = nullptr;
  const JxlPixelFormat format{std::uint32_t(in.channels), JXL_TYPE_UINT8, JXL_NATIVE_ENDIAN, 0};
  if (JxlEncoderSetBasicInfo(enc.get(), &info) != JXL_ENC_SUCCESS ||
      JxlEncoderSetColorEncoding(enc.get(), &colour) != JXL_ENC_SUCCESS ||
      !(frame = JxlEncoderFrameSettingsCreate(enc.get(), nullptr)) ||
      JxlEncoderSetFrameDistance(frame, jxl_distance(quality)) != JXL_ENC_SUCCESS ||
      JxlEncoderFrameSettingsSetOption(frame, JXL_ENC_FRAME_SETTING_EFFORT, std::clamp(effort, 1, 9)) != JXL_ENC_SUCCESS ||
      JxlEncoderAddImageFrame(frame, &format, in.pixels.data(), in.pixels.size()) != JXL_ENC_SUCCESS)
    throw std::runtime_error("JPEG XL encoding failed (error " + std::to_string(int(JxlEncoderGetError(enc.get()))) + ")");
  JxlEncoderCloseInput(enc.get());
  std::string out(std::max<std::size_t>(4096, in.pixels.size() / 4), '\0');
  std::size_t used = 0;
  while (true) {
    auto* next = reinterpret_cast<std::uint8_t*>(out.data()) + used;
    std::size_t avail = out.size() - used;
    const JxlEncoderStatus status = JxlEncoderProcessOutput(enc.get(), &next, &avail);
    used = out.size() - avail;
    if (status == JXL_ENC_SUCCESS) break;
    if (status != JXL_ENC_NEED_MORE_OUTPUT) throw std::runtime_error("JPEG XL encoding failed");
    out.resize(out.size() * 2);
  }
  out.resize(used);
  return out;
}

}  // namespace

std::string encode_image(const Raster& image, ImageFormat format, const EncodeOptions& options) {
  if (image.empty() || image.channels < 1 || image.channels > 4)
    throw std::invalid_argument("nothing to encode");
  switch (format) {
    case ImageFormat::kJpeg: return encode_jpeg(image, options.jpeg_quality);
    case ImageFormat::kPng: return encode_png(image, options.png_level);
    case ImageFormat::kWebp: return encode_webp(image, options.webp_quality);
    case ImageFormat::kAvif: return encode_avif(image, options.avif_quality, options.avif_speed);
    case ImageFormat::kJxl: return encode_jxl(image, options.jxl_quality, options.jxl_effort);
  }
  throw std::invalid_argument("unknown format");
}

}  // namespace zoomwarp::tiles
