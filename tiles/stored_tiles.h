// Stored JPEG tiles read as they are, without decoding: for a request that asks for exactly one
// tile of an image stored with JPEG tiles (manifest compression "jpeg", jpeg_tiles.h), the answer
// is the level's JPEGTables and the tile's raw bytes made into one JPEG file (complete_jpeg).
// Edge tiles are stored padded to the full tile size; they are cropped to their real size
// losslessly (TurboJPEG's crop transform: the crop starts at 0,0, on an MCU boundary, so the
// coefficients are copied, not decoded).
//
// Level files are read with libtiff directly (not through OpenImageIO's ImageCache, which would
// decode): a bounded number of them stay open, least recently used closed first, each with its
// tables read once.
//
// Threads: every member may be called from any thread. One libtiff handle is not thread-safe, so
// reads of one level file are serialised (a raw tile read is one pread of a few kB); reads of
// different files run in parallel.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "tiles/store.h"

namespace zoomwarp::tiles {

// Whether `m`'s tiles can be sent as stored: JPEG tiles (RGB, from --tile-compression jpeg/auto).
// Images stored with zip, lzw or none, and those of earlier versions, cannot.
bool has_jpeg_tiles(const Manifest& m);

class StoredTiles {
 public:
  explicit StoredTiles(std::size_t max_open_files = 64);
  ~StoredTiles();
  StoredTiles(const StoredTiles&) = delete;
  StoredTiles& operator=(const StoredTiles&) = delete;

  // Tile (tx, ty) of level `level` (tiles of manifest.tile_size pixels from the level's top left)
  // as a complete JPEG file of the tile's real size: min(tile_size, level size - its origin).
  // Precondition: has_jpeg_tiles(image.manifest); std::invalid_argument if it does not hold or
  // the tile does not exist. std::runtime_error when the level file cannot be opened or read or
  // is not what the manifest says (a damaged store): never invalid_argument for those.
  std::string jpeg_tile(const ImageEntry& image, int level, int tx, int ty);

  // Level files open now (at most max_open_files).
  std::size_t open_files() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::tiles
