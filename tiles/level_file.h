// One pyramid level's tiled TIFF (tiles/README.md, "On-disk format"), written through libtiff with
// the tile compression split from the writing: the TileEncoder compresses a tile on any thread,
// write() appends encoded tiles to the file one at a time. libtiff's codecs are serial per file, so this
// split is what lets ingest compress a level's tiles on all cores (pyramid_builder.h).
//
// The files are what OpenImageIO's TIFF writer made before (and still reads): 8-bit RGB or RGBA
// (a 4th channel tagged as an unspecified extra sample, so no reader premultiplies it),
// horizontal-difference predictor with zip and lzw, zip:1 (the default) through ISA-L's igzip
// level 1 and the other zip levels through libdeflate at libtiff's levels ("zip:N", "zip" =
// zip:6), BigTIFF when the raw level exceeds 4000 MiB. They carry no DateTime tag: the same pixels
// always give the same bytes. "jpeg" (RGB only) stores YCbCr JPEG tiles with the tables in the
// JPEGTables tag (jpeg_tiles.h), as libtiff's own JPEG codec would, but compressed on any thread.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "tiles/jpeg_tiles.h"

namespace zoomwarp::tiles {

// How a level's tiles are compressed: "zip:1" … "zip:9", "zip" (= zip:6), "lzw", "none" or
// "jpeg" (then `jpeg` says how).
struct LevelCompression {
  std::string method = "zip:1";
  JpegTileFormat jpeg;
};

// How a level's tiles become stored bytes: a small value, usable on many threads at once.
class TileEncoder {
 public:
  // The bytes to store for one full tile (tile_size² pixels, edges already padded), row-major.
  std::vector<std::uint8_t> operator()(std::span<const std::uint8_t> tile) const;

  int tile_size() const { return tile_size_; }
  int channels() const { return channels_; }

 private:
  friend class LevelFile;
  int tile_size_ = 256, channels_ = 3;
  int zip_quality_ = 0;  // 1…9; 0: stored as is (none), or encoded by libtiff when written (lzw)
  bool jpeg_ = false;    // JPEG tiles in jpeg_format_
  JpegTileFormat jpeg_format_;
};

class LevelFile {
 public:
  // Creates `path`. Throws IngestError (kIo) when the file cannot be created,
  // std::invalid_argument for an unknown compression, an invalid JPEG format or JPEG with alpha.
  LevelFile(const std::string& path, int width, int height, int channels, int tile_size,
            const LevelCompression& compression);
  ~LevelFile();  // closes the file if close() was not called (it is then incomplete)
  LevelFile(const LevelFile&) = delete;
  LevelFile& operator=(const LevelFile&) = delete;

  const TileEncoder& encoder() const { return encoder_; }

  // Stores tile (tx, ty) (tile column and row) as encoder() made it; `encoded` may be changed
  // (libtiff applies lzw's predictor in place). One thread at a time; the file's bytes depend on
  // the order of the calls. Throws IngestError (kIo).
  void write(int tx, int ty, std::span<std::uint8_t> encoded);

  // Writes the directory and closes. Throws IngestError (kIo).
  void close();

 private:
  struct Tiff;
  std::unique_ptr<Tiff> tiff_;
  TileEncoder encoder_;
  bool libtiff_encodes_ = false;  // lzw: the tile is handed to libtiff as pixels
};

}  // namespace zoomwarp::tiles
