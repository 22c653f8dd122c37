#include "tiles/encode.h"

#include <png.h>
#include <turbojpeg.h>
#include <webp/encode.h>

#include <algorithm>
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

std::string encode_webp(const Raster& in, int quality) {
  if (in.width > kWebpMaxDimension || in.height > kWebpMaxDimension)
    throw std::invalid_argument("WebP images are at most 16383 pixels wide and high");
  // WebP has no grey modes: expand grey (and grey+alpha) to RGB(A).
  const Raster* src = &in;
  Raster expanded;
  if (in.channels <= 2) {
    expanded = Raster(in.width, in.height, in.channels + 2);
    const std::size_t n = std::size_t(in.width) * in.height;
    for (std::size_t i = 0; i < n; ++i) {
      std::uint8_t* o = expanded.pixels.data() + i * expanded.channels;
      const std::uint8_t* p = in.pixels.data() + i * in.channels;
      o[0] = o[1] = o[2] = p[0];
      if (in.channels == 2) o[3] = p[1];
    }
    src = &expanded;
  }
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

}  // namespace

std::string encode_image(const Raster& image, ImageFormat format, const EncodeOptions& options) {
  if (image.empty() || image.channels < 1 || image.channels > 4)
    throw std::invalid_argument("nothing to encode");
  switch (format) {
    case ImageFormat::kJpeg: return encode_jpeg(image, options.jpeg_quality);
    case ImageFormat::kPng: return encode_png(image, options.png_level);
    case ImageFormat::kWebp: return encode_webp(image, options.webp_quality);
  }
  throw std::invalid_argument("unknown format");
}

}  // namespace zoomwarp::tiles
