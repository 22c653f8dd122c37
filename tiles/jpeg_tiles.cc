#include "tiles/jpeg_tiles.h"

// jpeglib.h needs size_t and FILE declared first.
#include <cstddef>
#include <cstdio>
#include <csetjmp>
#include <jpeglib.h>

#include <stdexcept>

namespace zoomwarp::tiles {

namespace {

// libjpeg reports errors by calling error_exit, which must not return: it jumps back to the
// setjmp in the call that started the work (C code between them holds no C++ object).
struct ErrorManager {
  jpeg_error_mgr pub;
  std::jmp_buf jump;
};

[[noreturn]] void jump_back(j_common_ptr c) { std::longjmp(reinterpret_cast<ErrorManager*>(c->err)->jump, 1); }
void no_message(j_common_ptr) {}

// Compressed bytes go into a buffer sized beforehand for any tile (see reserve()); a stream that
// would not fit is an error rather than a reallocation inside libjpeg.
struct BufferDestination {
  jpeg_destination_mgr pub;
  std::vector<std::uint8_t>* out;
};

void start_buffer(j_compress_ptr c) {
  auto* d = reinterpret_cast<BufferDestination*>(c->dest);
  d->pub.next_output_byte = d->out->data();
  d->pub.free_in_buffer = d->out->size();
}
boolean buffer_full(j_compress_ptr c) { jump_back(reinterpret_cast<j_common_ptr>(c)); }
void end_buffer(j_compress_ptr c) {
  auto* d = reinterpret_cast<BufferDestination*>(c->dest);
  d->out->resize(d->out->size() - d->pub.free_in_buffer);
}

// One libjpeg compressor, set up for one format: what each thread keeps.
struct Compressor {
  jpeg_compress_struct c{};
  ErrorManager err{};
  BufferDestination dest{};
  JpegTileFormat format{0, 0, 0};  // none yet
  int size = 0;
  bool created = false;

  Compressor() {
    c.err = jpeg_std_error(&err.pub);
    err.pub.error_exit = jump_back;
    err.pub.output_message = no_message;
    dest.pub.init_destination = start_buffer;
    dest.pub.empty_output_buffer = buffer_full;
    dest.pub.term_destination = end_buffer;
  }
  ~Compressor() {
    if (created) jpeg_destroy_compress(&c);
  }
};

// Sets `k` up for `f` and `size`² RGB input; with `tables_only`, writes the tables into `out`
// instead. Returns false when libjpeg failed (out of memory, or a stream larger than `out`).
bool set_up(Compressor& k, const JpegTileFormat& f, int size, std::vector<std::uint8_t>& out, bool tables_only) {
  if (setjmp(k.err.jump)) return false;
  if (!k.created) {
    jpeg_create_compress(&k.c);
    k.created = true;
    k.c.dest = &k.dest.pub;
  }
  k.dest.out = &out;
  if (k.format == f && k.size == size && !tables_only) return true;
  k.format = {0, 0, 0};
  k.c.image_width = JDIMENSION(size);
  k.c.image_height = JDIMENSION(size);
  k.c.input_components = 3;
  k.c.in_color_space = JCS_RGB;
  jpeg_set_defaults(&k.c);  // YCbCr, the Annex K Huffman tables
  jpeg_set_quality(&k.c, f.quality, TRUE);
  k.c.comp_info[0].h_samp_factor = f.chroma_h;
  k.c.comp_info[0].v_samp_factor = f.chroma_v;
  for (int i = 1; i < 3; ++i) k.c.comp_info[i].h_samp_factor = k.c.comp_info[i].v_samp_factor = 1;
  k.c.dct_method = JDCT_ISLOW;
  k.c.optimize_coding = FALSE;   // shared tables (see the header)
  k.c.write_JFIF_header = FALSE;  // TIFF's tags say what the JFIF marker would
  if (tables_only) {
    jpeg_write_tables(&k.c);
    return true;
  }
  jpeg_suppress_tables(&k.c, TRUE);  // abbreviated: the tables are in JPEGTables
  k.format = f;
  k.size = size;
  return true;
}

bool compress(Compressor& k, std::span<const std::uint8_t> rgb, int size) {
  if (setjmp(k.err.jump)) {
    jpeg_abort_compress(&k.c);
    return false;
  }
  jpeg_start_compress(&k.c, FALSE);
  const std::size_t row = std::size_t(size) * 3;
  while (k.c.next_scanline < k.c.image_height) {
    JSAMPROW r = const_cast<JSAMPROW>(rgb.data() + k.c.next_scanline * row);  // libjpeg only reads it
    jpeg_write_scanlines(&k.c, &r, 1);
  }
  jpeg_finish_compress(&k.c);
  return true;
}

// A baseline JPEG is not larger than this for `pixels` RGB pixels at any quality: at quality 100
// noise costs about 1.5× its raw size, and headers are small.
std::size_t worst_case_bytes(std::size_t pixels) { return pixels * 3 * 2 + 4096; }

}  // namespace

bool is_valid(const JpegTileFormat& f) {
  const bool sampling = (f.chroma_h == 2 && (f.chroma_v == 2 || f.chroma_v == 1)) || (f.chroma_h == 1 && f.chroma_v == 1);
  return f.quality >= 1 && f.quality <= 100 && sampling;
}

std::vector<std::uint8_t> jpeg_tile_tables(const JpegTileFormat& f) {
  if (!is_valid(f)) throw std::invalid_argument("invalid JPEG tile format");
  Compressor k;
  std::vector<std::uint8_t> out(4096);
  if (!set_up(k, f, 16, out, true)) throw std::runtime_error("cannot write JPEG tables");
  return out;
}

std::vector<std::uint8_t> encode_jpeg_tile(const JpegTileFormat& f, std::span<const std::uint8_t> rgb, int size) {
  if (!is_valid(f)) throw std::invalid_argument("invalid JPEG tile format");
  if (size <= 0 || rgb.size() != std::size_t(size) * size * 3) throw std::invalid_argument("JPEG tile: wrong pixel count");
  thread_local Compressor k;
  thread_local std::vector<std::uint8_t> scratch;
  scratch.resize(worst_case_bytes(std::size_t(size) * size));
  if (!set_up(k, f, size, scratch, false) || !compress(k, rgb, size)) throw std::runtime_error("JPEG tile compression failed");
  return scratch;  // a copy at its size: the tiles in flight hold only their bytes
}

std::string complete_jpeg(std::span<const std::uint8_t> tables, std::span<const std::uint8_t> tile) {
  const auto starts = [](std::span<const std::uint8_t> s, std::uint8_t a, std::uint8_t b) {
    return s.size() >= 4 && s[0] == a && s[1] == b;
  };
  const auto ends_eoi = [](std::span<const std::uint8_t> s) { return s[s.size() - 2] == 0xFF && s[s.size() - 1] == 0xD9; };
  if (!starts(tables, 0xFF, 0xD8) || !ends_eoi(tables) || !starts(tile, 0xFF, 0xD8))
    throw std::invalid_argument("not a JPEG-in-TIFF tile");
  std::string out;
  out.reserve(tables.size() + tile.size());
  out.append(reinterpret_cast<const char*>(tables.data()), tables.size() - 2);  // SOI, DQT, DHT
  out.append(reinterpret_cast<const char*>(tile.data()) + 2, tile.size() - 2);   // SOF … EOI
  return out;
}

}  // namespace zoomwarp::tiles
