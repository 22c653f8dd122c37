// The files of one image version — its pyramid's levels, manifest.json, and the analyses added to
// it (warp/analysis/derived_files.h) — wherever the store keeps them: a folder on a filesystem, or
// objects in a bucket (issue 29). Code above tiles/ reads and adds a version's files only through
// this interface, so it never knows which store it runs on.
//
// A published version's pyramid and manifest never change. Files may be added to it (derived data,
// a pure function of the version: whichever writer's bytes land, readers compute the same views);
// write() is atomic, so a reader sees the whole old file, the whole new one, or none.
//
// Thread safety: every member may be called from any thread, also from several processes at once.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tiles/random_access_file.h"

namespace zoomwarp::tiles {

class VersionFiles {
 public:
  virtual ~VersionFiles() = default;

  // The whole file `name`, or nullopt when the version has no such file. Throws
  // std::runtime_error when the store cannot answer (unreadable, unreachable).
  virtual std::optional<std::string> read(const std::string& name) const = 0;
  virtual bool exists(const std::string& name) const = 0;
  // Every file the version holds (manifest.json included), in no particular order; writers'
  // temporaries are not files of the version.
  virtual std::vector<std::string> names() const = 0;

  // Writes `name` atomically (a temporary of this writer's own, then renamed or committed), also
  // over an existing file or a hard link to an older version's file, which is replaced, never
  // written through. Throws std::runtime_error, leaving nothing behind, when it cannot.
  virtual void write(const std::string& name, const std::string& bytes) const = 0;

  // `name` opened for reads by byte range (the level readers: a tile is one range), or null when
  // the version has no such file. Throws std::runtime_error when the store cannot answer.
  virtual std::shared_ptr<const RandomAccessFile> open(const std::string& name) const = 0;

  // A local path to `name` for readers that open files themselves (libtiff, OpenImageIO; faster
  // than through open() for a file that is local), or nullopt when the files are not local.
  virtual std::optional<std::string> local_path(const std::string& name) const = 0;

  // Names the version's location in messages and as a cache key: one string per version and
  // store, never shared by two versions.
  virtual const std::string& location() const = 0;
};

// A version's files in a folder: `dir` (a published version, or a staging folder being built).
std::shared_ptr<const VersionFiles> folder_files(std::string dir);

}  // namespace zoomwarp::tiles
