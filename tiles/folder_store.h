// A Store's images in a folder on a filesystem — a local disk or a shared mount (NFS, CephFS,
// EFS) that every replica sees:
//
//   ROOT/images/ID          symlink to ../versions/ID@VERSION: the pointer
//   ROOT/versions/ID@VERSION/manifest.json, level_K.tif   one immutable image version
//   ROOT/staging/HOST.PID.RANDOM/                        work in progress, never read
//   ROOT/locks/ID                                        flock()ed around commits and removes
//
// A commit renames the finished staging folder into versions/ and then atomically replaces the
// images/ID link (a new link renamed over it), so a reader sees the old version or the new one.
#pragma once

#include <memory>
#include <string>

#include "tiles/store_backend.h"

namespace zoomwarp::tiles {

// Creates ROOT and its folders if missing; throws std::runtime_error if it cannot.
std::unique_ptr<StoreBackend> folder_store(const std::string& root);

}  // namespace zoomwarp::tiles
