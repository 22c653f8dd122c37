// JPEG-compressed pyramid tiles, as JPEG-in-TIFF stores them (TIFF Technical Note #2, the form
// libtiff, vips tiffsave and iipsrv's pyramids use): each tile is an abbreviated baseline JPEG
// stream (SOI, SOF, SOS, scan, EOI) in YCbCr with chroma subsampling, and the quantisation and
// Huffman tables, the same for every tile of a level, are stored once in the file's JPEGTables
// tag. Standard Huffman tables (not optimised per tile) are what lets every tile share them.
//
// A stored tile becomes a complete JPEG file — what a client is sent when its request is exactly
// that tile (api/README.md, "Stored tiles sent as they are") — by putting the tables in front of
// it: complete_jpeg(). No pixel is decoded.
//
// Pure functions: safe to call from any thread (each thread keeps its own libjpeg compressor).
#pragma once

#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace zoomwarp::tiles {

struct JpegTileFormat {
  int quality = 90;  // IJG quality 1…100 (libjpeg's scaling of the Annex K tables)
  // Luma samples per chroma sample, horizontally and vertically: 2×2 (4:2:0), 2×1 (4:2:2) or 1×1
  // (4:4:4). TIFF's YCbCrSubsampling tag says the same to readers.
  int chroma_h = 2, chroma_v = 2;

  bool operator==(const JpegTileFormat&) const = default;
};

// True when `f` is a format these functions can write: quality 1…100, subsampling 2×2, 2×1, 1×1.
bool is_valid(const JpegTileFormat& f);

// The tables every tile of format `f` uses, as an abbreviated table-specification stream
// (SOI, DQT, DHT, EOI): the JPEGTables tag's value.
std::vector<std::uint8_t> jpeg_tile_tables(const JpegTileFormat& f);

// One `size`×`size` RGB tile (row-major, edges already padded) as an abbreviated JPEG stream
// without tables. The accurate integer DCT: the stored pixels are the ones every later answer is
// made from. Deterministic: the same pixels and format give the same bytes on any thread.
std::vector<std::uint8_t> encode_jpeg_tile(const JpegTileFormat& f, std::span<const std::uint8_t> rgb, int size);

// A complete JPEG file made of a level's tables and one of its stored tiles (both as above):
// SOI, the tables, then the tile's frame and scan. Throws std::invalid_argument when either is
// not a JPEG stream of that shape (a damaged file).
std::string complete_jpeg(std::span<const std::uint8_t> tables, std::span<const std::uint8_t> tile);

}  // namespace zoomwarp::tiles
