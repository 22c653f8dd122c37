// A JPEG 2000 source (JP2 or a raw J2K codestream) read row by row in memory bounded by a tile
// row, not by the image (issue 42): OpenImageIO 2.4's reader decodes the whole image when it
// opens it, 1.35 GB for a 100 MP lossy JP2 that `vips dzsave` reads in 166 MB. OpenJPEG is used
// directly, as iipsrv and vips do:
//
//   tiled codestreams (vips jp2ksave, Kakadu, opj_compress -t: the usual master)
//       tile by tile, in codestream order (opj_read_tile_header / opj_decode_tile_data); a tile
//       row's tiles are assembled into a band one tile high and the image's width, handed out as
//       rows, then dropped. Memory: one band, one tile, and the tiles of a later row that came
//       early (none in raster order).
//   one tile for the whole image (opj_compress without -t; OpenJPEG issue #1167's 15 GB)
//       by bands of rows, each an opj_set_decode_area() and opj_decode() on the one tile, which
//       OpenJPEG 2.3+ allows repeatedly and which decodes only the code-blocks the band touches.
//       Memory: the codestream (OpenJPEG reads the one tile's data whole) and, over a band,
//       OpenJPEG's samples, wavelet and code-blocks, about 8 times the band's 32-bit samples. Each
//       band parses the tile's packet headers again: 32 MB of samples a band took a 100 MP lossy
//       JP2 in 10.4 s and 398 MB, 128 MB in 7.9 s and 786 MB (vips dzsave: 13.1 s, 220 MB).
//
// The coarse levels are halved from the rows (pyramid_builder.cc), not decoded again at reduced
// resolution: halving costs a few per cent of decoding, and a second decode at resolution
// factor r would run the entropy decoder again over the codestream's lower resolutions.
//
// What it takes: 1-4 components of one size (no subsampled chroma), 1-16 bits, signed or not, in
// sRGB, grey or unspecified colour (the last read as sRGB, as OpenImageIO does). Others (sYCC
// with subsampled chroma, CMYK, e-YCC) are `supported() == false`: the caller decodes them whole
// with OpenImageIO, within its memory limit. An embedded ICC profile is handed on (icc_profile).
//
// Threads: one object per thread; OpenJPEG's own threads decode code-blocks in parallel.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace zoomwarp::tiles {

class Jpeg2000Rows {
 public:
  // Reads the header of `path` (a "jp2" or "j2k" as sniff_image_file() names them). Throws
  // IngestError (kCorrupt) when OpenJPEG cannot read it. `threads`: OpenJPEG's decoding threads.
  // `untiled_band_bytes`: how many bytes of OpenJPEG's 32-bit samples an untiled codestream's
  // band holds (fewer, larger bands are faster: each parses the tile's packet headers again).
  static constexpr std::uint64_t kUntiledBandBytes = 32ull << 20;
  Jpeg2000Rows(const std::string& path, const std::string& format, int threads,
               std::uint64_t untiled_band_bytes = kUntiledBandBytes);
  ~Jpeg2000Rows();
  Jpeg2000Rows(const Jpeg2000Rows&) = delete;
  Jpeg2000Rows& operator=(const Jpeg2000Rows&) = delete;

  // Whether read() can decode this codestream (see above); why not, when it cannot.
  bool supported() const { return why_not_.empty(); }
  const std::string& why_not() const { return why_not_; }

  int width() const { return width_; }
  int height() const { return height_; }
  int components() const { return components_; }  // all of them
  int bits() const { return bits_; }              // the largest precision
  bool tiled() const { return tiles_x_ * tiles_y_ > 1; }
  int band_rows() const;  // rows decoded at once: a tile row's (tiled), or an untiled band's
  const std::vector<std::uint8_t>& icc_profile() const { return icc_; }

  // The most bytes read() holds at once for this image (a band and a tile, or an untiled band and
  // OpenJPEG's window), for the caller's memory limit.
  std::uint64_t peak_bytes() const;

  // Rows [y0, y1) of the first `channels` (≤ components()) components, 8-bit, interleaved, into
  // `out`. Rows are asked for in order, each once. Throws IngestError (kCorrupt) on a decoding
  // error or a truncated codestream.
  void read(int y0, int y1, int channels, std::uint8_t* out);

 private:
  struct Codec;
  void next_band();            // makes the band after the current one band_
  void decode_tiled_band();    // tile by tile
  void decode_untiled_band();  // by decode area

  std::unique_ptr<Codec> codec_;
  std::string why_not_;
  int width_ = 0, height_ = 0, components_ = 0, bits_ = 8;
  int x0_ = 0, y0_ = 0;                  // the image area's origin on the reference grid
  int tile_w_ = 0, tile_h_ = 0, tile_x0_ = 0, tile_y0_ = 0;
  int tiles_x_ = 1, tiles_y_ = 1;
  std::uint64_t codestream_bytes_ = 0;  // untiled: the file's size, which OpenJPEG holds
  std::vector<std::uint8_t> icc_;
  // The band being handed out: rows [band_y0_, band_y1_) of the image, every component, 8-bit,
  // interleaved (components_ bytes a pixel).
  std::vector<std::uint8_t> band_;
  int band_y0_ = 0, band_y1_ = 0, band_rows_ = 0;
  int next_band_row_ = 0;  // tiled: the tile row handed out next
  // Tiled: the tile rows being assembled, by index (the next one, and any whose tiles came early).
  struct PendingBand {
    std::vector<std::uint8_t> pixels;
    int tiles_done = 0;
  };
  std::map<int, PendingBand> pending_;
  std::vector<std::uint8_t> tile_data_;  // one tile's samples as OpenJPEG hands them over
};

}  // namespace zoomwarp::tiles
