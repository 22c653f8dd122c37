#include "tiles/stored_tiles.h"

#include <tiffio.h>
#include <turbojpeg.h>

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <list>
#include <mutex>
#include <span>
#include <stdexcept>
#include <unordered_map>
#include <vector>

#include "tiles/jpeg_tiles.h"
#include "tiles/pyramid_builder.h"
#include "tiles/tiff_on_file.h"

namespace zoomwarp::tiles {

namespace {

// A stored tile larger than this is a damaged byte count, not a tile: a 256² tile at quality 100
// without subsampling is about 200 kB.
constexpr std::uint64_t kMaxTileBytes = 16u << 20;

// libtiff reports through handlers; this one keeps the file's last message for the exception.
int keep_message(TIFF*, void* user_data, const char*, const char* fmt, va_list ap) {
  char text[512];
  std::vsnprintf(text, sizeof text, fmt, ap);
  *static_cast<std::string*>(user_data) = text;
  return 1;  // handled: nothing on stderr
}

// One open level file: its handle, its tables, and the lock a libtiff handle needs.
struct Level {
  std::string path;
  std::string message;  // libtiff's last error or warning (the handlers write here)
  TIFF* tif = nullptr;
  std::unique_ptr<TiffOnFile> remote;  // a file read by range (a bucket's); owns tif then
  std::vector<std::uint8_t> tables;
  std::uint32_t width = 0, height = 0, tile_size = 0;
  std::mutex mu;

  explicit Level(std::string p) : path(std::move(p)) {}
  ~Level() {
    if (tif && !remote) TIFFClose(tif);
  }
  [[noreturn]] void fail(const std::string& what) const {
    throw std::runtime_error(path + ": " + what + (message.empty() ? "" : " (" + message + ")"));
  }
};

// Opens level k of `image` (a local file by its path, else by byte range) and checks it is the
// JPEG-tiled level the manifest describes.
std::shared_ptr<Level> open_level(const ImageEntry& image, int k) {
  const Manifest& m = image.manifest;
  const std::string name = level_filename(k);
  const std::optional<std::string> local = image.files->local_path(name);
  auto level = std::make_shared<Level>(local ? *local : image.files->location() + "/" + name);
  std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> opts(TIFFOpenOptionsAlloc(), TIFFOpenOptionsFree);
  TIFFOpenOptionsSetErrorHandlerExtR(opts.get(), keep_message, &level->message);
  TIFFOpenOptionsSetWarningHandlerExtR(opts.get(), keep_message, &level->message);
  if (local) {
    level->tif = TIFFOpenExt(local->c_str(), "r", opts.get());
  } else if (auto file = image.files->open(name)) {
    level->remote = std::make_unique<TiffOnFile>(std::move(file), opts.get());
    level->tif = level->remote->tif();
  }
  if (!level->tif) level->fail("cannot open");
  TIFF* t = level->tif;
  std::uint16_t compression = 0;
  std::uint32_t tile_h = 0, count = 0;
  void* tables = nullptr;
  if (!TIFFGetField(t, TIFFTAG_COMPRESSION, &compression) || compression != COMPRESSION_JPEG)
    level->fail("not JPEG-compressed");
  if (!TIFFGetField(t, TIFFTAG_IMAGEWIDTH, &level->width) || !TIFFGetField(t, TIFFTAG_IMAGELENGTH, &level->height) ||
      !TIFFGetField(t, TIFFTAG_TILEWIDTH, &level->tile_size) || !TIFFGetField(t, TIFFTAG_TILELENGTH, &tile_h))
    level->fail("not a tiled image");
  if (level->width != std::uint32_t(m.level_width(k)) || level->height != std::uint32_t(m.level_height(k)) ||
      level->tile_size != std::uint32_t(m.tile_size) || tile_h != level->tile_size)
    level->fail("size or tiles differ from the manifest");
  if (!TIFFGetField(t, TIFFTAG_JPEGTABLES, &count, &tables) || !tables || count < 4) level->fail("no JPEGTables");
  const auto* bytes = static_cast<const std::uint8_t*>(tables);
  level->tables.assign(bytes, bytes + count);
  return level;
}

// The raw (abbreviated JPEG) bytes of tile (tx, ty); the caller holds level.mu.
std::vector<std::uint8_t> read_raw_tile(Level& level, int tx, int ty) {
  const std::uint32_t x = std::uint32_t(tx) * level.tile_size, y = std::uint32_t(ty) * level.tile_size;
  const std::uint32_t tile = TIFFComputeTile(level.tif, x, y, 0, 0);
  if (tile >= TIFFNumberOfTiles(level.tif)) level.fail("tile " + std::to_string(tile) + " missing");
  int err = 0;
  const std::uint64_t size = TIFFGetStrileByteCountWithErr(level.tif, tile, &err);
  if (err || size == 0 || size > kMaxTileBytes) level.fail("tile " + std::to_string(tile) + " has a damaged byte count");
  std::vector<std::uint8_t> raw(size);
  const tmsize_t got = TIFFReadRawTile(level.tif, tile, raw.data(), tmsize_t(size));
  if (got != tmsize_t(size) && level.remote) level.remote->rethrow_read_failure();
  if (got != tmsize_t(size)) level.fail("tile " + std::to_string(tile) + " cannot be read");
  return raw;
}

// `jpeg` cropped to its top-left w × h without decoding: the coefficients of the blocks kept are
// copied (the crop's origin 0,0 is on an MCU boundary). Throws std::runtime_error on a damaged JPEG.
std::string crop_top_left(const std::string& jpeg, int w, int h) {
  thread_local std::unique_ptr<void, int (*)(tjhandle)> tj(tjInitTransform(), tjDestroy);
  if (!tj) throw std::runtime_error("cannot start a TurboJPEG transform");
  tjtransform xf{};
  xf.r = tjregion{0, 0, w, h};
  xf.op = TJXOP_NONE;
  xf.options = TJXOPT_CROP;
  unsigned char* out = nullptr;
  unsigned long out_size = 0;
  const int rc = tjTransform(tj.get(), reinterpret_cast<const unsigned char*>(jpeg.data()), jpeg.size(), 1, &out,
                             &out_size, &xf, 0);
  std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(out, tjFree);
  if (rc != 0) throw std::runtime_error(std::string("stored tile cannot be cropped: ") + tjGetErrorStr2(tj.get()));
  return std::string(reinterpret_cast<const char*>(out), out_size);
}

}  // namespace

bool has_jpeg_tiles(const Manifest& m) { return m.compression == "jpeg" && m.channels == 3; }

struct StoredTiles::Impl {
  std::size_t capacity;
  mutable std::mutex mu;  // guards the two below
  std::list<std::shared_ptr<Level>> recent;  // most recently used first
  std::unordered_map<std::string, std::list<std::shared_ptr<Level>>::iterator> by_path;

  // The open level file at `path`, opened (outside the lock: it reads the file's directory) if it
  // is not. A level evicted while another thread reads it closes when that read ends.
  std::shared_ptr<Level> level(const ImageEntry& image, int k) {
    const std::string path = image.files->location() + "/" + level_filename(k);
    {
      std::lock_guard lock(mu);
      if (auto it = by_path.find(path); it != by_path.end()) {
        recent.splice(recent.begin(), recent, it->second);
        return *it->second;
      }
    }
    auto opened = open_level(image, k);
    std::lock_guard lock(mu);
    if (auto it = by_path.find(path); it != by_path.end()) return *it->second;  // another thread was first
    recent.push_front(opened);
    by_path[path] = recent.begin();
    while (recent.size() > capacity) {
      by_path.erase(recent.back()->path);
      recent.pop_back();
    }
    return opened;
  }
};

StoredTiles::StoredTiles(std::size_t max_open_files) : impl_(std::make_unique<Impl>()) {
  impl_->capacity = std::max<std::size_t>(1, max_open_files);
}

StoredTiles::~StoredTiles() = default;

std::string StoredTiles::jpeg_tile(const ImageEntry& image, int level, int tx, int ty) {
  const Manifest& m = image.manifest;
  if (!has_jpeg_tiles(m)) throw std::invalid_argument("image " + m.id + " has no JPEG tiles");
  if (level < 0 || level >= m.levels || tx < 0 || ty < 0 ||
      std::int64_t(tx) * m.tile_size >= m.level_width(level) || std::int64_t(ty) * m.tile_size >= m.level_height(level))
    throw std::invalid_argument("no such stored tile");
  std::shared_ptr<Level> file = impl_->level(image, level);
  std::vector<std::uint8_t> raw;
  {
    std::lock_guard lock(file->mu);
    raw = read_raw_tile(*file, tx, ty);
  }
  std::string jpeg;
  try {
    jpeg = complete_jpeg(file->tables, raw);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(file->path + ": " + e.what());  // a damaged file: the server's failure
  }
  const int w = std::min<int>(m.tile_size, m.level_width(level) - tx * m.tile_size);
  const int h = std::min<int>(m.tile_size, m.level_height(level) - ty * m.tile_size);
  return w == m.tile_size && h == m.tile_size ? jpeg : crop_top_left(jpeg, w, h);
}

std::size_t StoredTiles::open_files() const {
  std::lock_guard lock(impl_->mu);
  return impl_->recent.size();
}

}  // namespace zoomwarp::tiles
