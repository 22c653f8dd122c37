#include "tiles/tiff_on_file.h"

#include <cstdio>
#include <stdexcept>
#include <utility>

namespace zoomwarp::tiles {

namespace {

using State = TiffOnFile::State;

tmsize_t read_proc(thandle_t handle, void* buffer, tmsize_t size) {
  auto* s = static_cast<State*>(handle);
  if (size <= 0) return 0;
  try {
    const std::size_t got = s->file->read(s->position, std::size_t(size), static_cast<char*>(buffer));
    s->position += got;
    return tmsize_t(got);
  } catch (...) {
    if (!s->failure) s->failure = std::current_exception();
    return -1;
  }
}

tmsize_t write_proc(thandle_t, void*, tmsize_t) { return -1; }  // read-only

toff_t seek_proc(thandle_t handle, toff_t offset, int whence) {
  auto* s = static_cast<State*>(handle);
  switch (whence) {
    case SEEK_SET: s->position = offset; break;
    case SEEK_CUR: s->position += offset; break;
    case SEEK_END: s->position = s->file->size() + offset; break;
    default: return toff_t(-1);
  }
  return s->position;
}

int close_proc(thandle_t) { return 0; }

toff_t size_proc(thandle_t handle) { return static_cast<State*>(handle)->file->size(); }

int map_proc(thandle_t, void**, toff_t*) { return 0; }  // no mapping: libtiff reads instead

void unmap_proc(thandle_t, void*, toff_t) {}

}  // namespace

TiffOnFile::TiffOnFile(std::shared_ptr<const RandomAccessFile> file, TIFFOpenOptions* options) {
  state_.file = std::move(file);
  tif_ = TIFFClientOpenExt(state_.file->name().c_str(), "rm", &state_, read_proc, write_proc, seek_proc, close_proc,
                           size_proc, map_proc, unmap_proc, options);
  if (!tif_) {
    rethrow_read_failure();
    throw std::runtime_error(state_.file->name() + ": not a TIFF file libtiff can open");
  }
}

TiffOnFile::~TiffOnFile() {
  if (tif_) TIFFClose(tif_);
}

void TiffOnFile::rethrow_read_failure() {
  if (!state_.failure) return;
  std::exception_ptr failure = std::exchange(state_.failure, nullptr);
  std::rethrow_exception(failure);
}

}  // namespace zoomwarp::tiles
