// Where a Store (tiles/store.h) keeps its images: the few primitives its semantics are built on,
// implemented by a folder on a filesystem (folder_store.h) and by a bucket of an S3-compatible
// object store. Store adds what both share: the version's name, its manifest, the remembered
// pointer readings and loaded versions, the order of a publish's steps.
//
// Layout, in both (a key prefix in a bucket, a folder on disk):
//   images/ID                  the pointer: which version of ID is published (ID@VERSION)
//   versions/ID@VERSION/…      one immutable version: manifest.json, level_K.tif, analyses
//   superseded/ID@VERSION      when VERSION stopped being published (superseded_versions.h)
//   locks/ID                   who may move images/ID now (a flock()ed file; a bucket's lease)
// Staging folders, where a version is built before it is committed, are always local.
//
// Thread safety: every member may be called from any thread; across processes, point() and
// remove_pointer() of one id are serialised by the lock lock_id() takes.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tiles/range_cache.h"
#include "tiles/s3_client.h"
#include "tiles/version_files.h"

namespace zoomwarp::tiles {

// What a remote store did and holds, for metrics and cost reports (issue 29); all zero for a folder.
struct StoreStats {
  bool remote = false;
  S3Stats requests;
  RangeCacheStats cache;
};

class StoreBackend {
 public:
  virtual ~StoreBackend() = default;

  // The store's root folder, or its s3://BUCKET/PREFIX: for messages and logs.
  virtual const std::string& location() const = 0;

  // The version directory ("ID@VERSION") that images/ID points to now, or nullopt when it points
  // nowhere valid. Read from the store on every call (Store remembers readings).
  virtual std::optional<std::string> read_pointer(const std::string& id) const = 0;
  // Whether images/ID exists, whatever it points to.
  virtual bool has_pointer(const std::string& id) const = 0;
  // Every id with a pointer, in no particular order.
  virtual std::vector<std::string> pointer_ids() const = 0;

  // The files of versions/VERSION_DIR (which may not exist: its reads then find nothing).
  virtual std::shared_ptr<const VersionFiles> version_files(const std::string& version_dir) const = 0;

  // A new, empty local folder to build a version in; discard_staging() removes one.
  virtual std::string make_staging_dir() const = 0;
  virtual void discard_staging(const std::string& staging_dir) const = 0;
  // Puts every file of versions/VERSION_DIR but its manifest into the staging folder `staging`,
  // for an edit that replaces a few of them (writing new files, never writing through what it
  // was given). Throws on failure; the caller discards the folder.
  virtual void copy_into_staging(const std::string& version_dir, const std::string& staging) const = 0;

  // An exclusive lock on `id` across every process sharing the store, held while the returned
  // object lives: a flock() on a folder, a lease in a bucket (bucket_lease.h). Throws
  // StoreUnavailable (timed out) when another process holds it past the thread's deadline.
  virtual std::shared_ptr<void> lock_id(const std::string& id) = 0;

  // Makes the finished `staging_dir` (manifest.json included) versions/VERSION_DIR, named by no
  // pointer yet (the collector leaves it for its grace). The staging folder is gone afterwards,
  // whether it succeeded or threw. Needs no lock: the version is new and its own.
  virtual void store_version(const std::string& staging_dir, const std::string& version_dir) = 0;
  // Points images/ID at the stored versions/VERSION_DIR: a reader sees the old version or the new
  // one. The version it replaces is marked superseded first. The caller holds lock_id(id); throws
  // StoreUnavailable, having changed nothing, when that lock may have lapsed.
  virtual void point(const std::string& id, const std::string& version_dir) = 0;
  // Marks the version images/ID names superseded and removes images/ID; false if there was none.
  virtual bool remove_pointer(const std::string& id) = 0;

  // Removes versions no pointer has named for `grace` (superseded_versions.h: by their marks,
  // marking the unnamed ones that have none; calling `removed` with each one's directory), and
  // staging folders of processes that are gone. Returns how many it removed.
  virtual int collect_garbage(std::chrono::seconds grace, const std::function<void(const std::string&)>& removed) = 0;

  // Why the store cannot be read now, or "" when it can (readiness): one small request, answered
  // or given up on within `within`.
  virtual std::string problem(std::chrono::milliseconds within) const = 0;

  virtual StoreStats stats() const { return {}; }
};

}  // namespace zoomwarp::tiles
