#include "tiles/raster_ops.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <stdexcept>

namespace zoomwarp::tiles {

namespace {

OIIO::ImageSpec spec_of(const Raster& r) {
  OIIO::ImageSpec s(r.width, r.height, r.channels, OIIO::TypeDesc::UINT8);
  s.alpha_channel = -1;
  return s;
}

// Applies an OIIO geometric operation from `in` into a new raster of size w×h.
template <class Op>
Raster apply(const Raster& in, int w, int h, Op op) {
  Raster out(w, h, in.channels);
  OIIO::ImageBuf src(spec_of(in), const_cast<std::uint8_t*>(in.pixels.data()));
  OIIO::ImageBuf dst(spec_of(out), out.pixels.data());
  if (!op(dst, src)) throw std::runtime_error("pixel operation failed: " + dst.geterror());
  return out;
}

bool has_alpha(const Raster& r) { return r.channels == 2 || r.channels == 4; }

std::uint8_t luma(const std::uint8_t* p, int channels) {
  if (channels <= 2) return p[0];
  return std::uint8_t((2126 * p[0] + 7152 * p[1] + 722 * p[2] + 5000) / 10000);
}

template <class Map>
Raster to_one_channel(const Raster& in, Map map) {
  const bool alpha = has_alpha(in);
  Raster out(in.width, in.height, alpha ? 2 : 1);
  const std::size_t n = std::size_t(in.width) * in.height;
  const std::uint8_t* p = in.pixels.data();
  std::uint8_t* o = out.pixels.data();
  for (std::size_t i = 0; i < n; ++i, p += in.channels, o += out.channels) {
    o[0] = map(luma(p, in.channels));
    if (alpha) o[1] = p[in.channels - 1];
  }
  return out;
}

}  // namespace

Raster mirror_horizontally(const Raster& in) {
  return apply(in, in.width, in.height,
               [](OIIO::ImageBuf& d, const OIIO::ImageBuf& s) { return OIIO::ImageBufAlgo::flop(d, s); });
}

Raster rotate_clockwise(const Raster& in, int degrees) {
  switch (degrees) {
    case 0:
      return in;
    case 90:
      return apply(in, in.height, in.width, [](OIIO::ImageBuf& d, const OIIO::ImageBuf& s) {
        return OIIO::ImageBufAlgo::rotate90(d, s);
      });
    case 180:
      return apply(in, in.width, in.height, [](OIIO::ImageBuf& d, const OIIO::ImageBuf& s) {
        return OIIO::ImageBufAlgo::rotate180(d, s);
      });
    case 270:
      return apply(in, in.height, in.width, [](OIIO::ImageBuf& d, const OIIO::ImageBuf& s) {
        return OIIO::ImageBufAlgo::rotate270(d, s);
      });
  }
  throw std::invalid_argument("rotation must be 0, 90, 180 or 270 degrees");
}

Raster to_grey(const Raster& in) {
  return to_one_channel(in, [](std::uint8_t y) { return y; });
}

Raster to_bitonal(const Raster& in) {
  return to_one_channel(in, [](std::uint8_t y) { return std::uint8_t(y >= 128 ? 255 : 0); });
}

Raster flatten_alpha(const Raster& in, std::uint8_t background) {
  if (!has_alpha(in)) return in;
  const int colour = in.channels - 1;
  Raster out(in.width, in.height, colour);
  const std::size_t n = std::size_t(in.width) * in.height;
  const std::uint8_t* p = in.pixels.data();
  std::uint8_t* o = out.pixels.data();
  for (std::size_t i = 0; i < n; ++i, p += in.channels, o += colour) {
    const unsigned a = p[colour];
    for (int c = 0; c < colour; ++c) o[c] = std::uint8_t((p[c] * a + background * (255 - a) + 127) / 255);
  }
  return out;
}

}  // namespace zoomwarp::tiles
