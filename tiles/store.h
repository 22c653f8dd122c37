// The store of published images, shared by every process (CLI ingest, server replicas): a folder
// (tiles/folder_store.h) or a bucket of an S3-compatible object store, behind one interface
// (tiles/store_backend.h); nothing above tiles/ knows which.
//
// Each image id points to one immutable version (ID@VERSION: its manifest, pyramid and analyses).
// Publishing builds a version in a local staging folder, commits it whole, and only then points
// the id at it, so a reader sees the old version or the new one, never a half-written one.
// Superseded and deleted versions stay for a grace period, for readers that resolved them just
// before; collect_garbage() removes them and staging folders of processes that died.
//
// Which version an id names is read at most once per `recheck` interval (1 s by default) and
// remembered meanwhile: a cached tile then costs no store access besides its write. This process's
// own publish() and remove() take effect at once; another process's (a replica sharing the store,
// a CLI ingest) within `recheck`. A version read just before it was superseded stays in the store
// for the garbage collector's grace period (minutes), so it is still readable. An id not found is
// never remembered: a new image is visible at once.
//
// Threads: every member may be called from any thread (the caches of pointers and of loaded
// versions are under mutexes). Across processes — replicas sharing a bucket included — every
// pointer move of one id is serialised by the backend's lock on the id (store_backend.h), so a
// conditional publish's check and move are one step: no edit made against a version is lost.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <shared_mutex>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "tiles/bucket_lease.h"
#include "tiles/manifest.h"
#include "tiles/store_backend.h"
#include "tiles/version_files.h"

namespace zoomwarp::tiles {

struct ImageEntry {
  Manifest manifest;
  std::shared_ptr<const VersionFiles> files;  // its levels, manifest and analyses
  // Level k's file as a local path, for the readers that open it themselves (tiles/ only).
  std::string level_path(int k) const;
};

// What a bucket store keeps on this host, and how it locks an image across replicas (ignored for
// a folder store).
struct BucketStoreOptions {
  // Staging folders and the disk cache of the bucket's bytes (bounded by disk_bytes; 0: none).
  // Empty: staging under $TMPDIR/zoomwarp-store-cache/BUCKET/PREFIX, and no disk cache.
  std::string dir;
  std::uint64_t disk_bytes = 10ULL << 30;
  // The bucket's bytes kept in memory: level files' blocks (headers, tile indexes, stored tiles)
  // and small files (manifests, analyses).
  std::size_t memory_bytes = 256u << 20;
  // The lease an edit's pointer move holds (bucket_lease.h).
  LeaseTiming lease;
};

struct VersionConflict : std::runtime_error {
  VersionConflict(const std::string& what, std::shared_ptr<const ImageEntry> stored = nullptr)
      : std::runtime_error(what), stored(std::move(stored)) {}
  // The version that was stored and then lost the check at the pointer move (null when the
  // first check failed): a caller may build on it again rather than start over.
  std::shared_ptr<const ImageEntry> stored;
};

class Store {
 public:
  static constexpr std::chrono::milliseconds kDefaultRecheck{1000};

  // The store at `location`: a folder (created with its subfolders if missing), or
  // s3://BUCKET/PREFIX (tiles/bucket_store.h; credentials and endpoint from the AWS environment).
  // Throws std::runtime_error if it cannot be opened: a folder that cannot be made, credentials
  // the bucket refuses, a bucket that does not exist. `recheck`: how long a pointer once read is
  // trusted (see above); 0 reads it on every find(). `cache`: what a bucket store keeps locally.
  explicit Store(const std::string& location, std::chrono::milliseconds recheck = kDefaultRecheck,
                 const BucketStoreOptions& cache = {});
  ~Store();

  // The folder, or s3://BUCKET/PREFIX: for messages and logs.
  const std::string& root() const;

  // The published version of `id` (which must be valid), or null. The link is read again once the
  // last reading is `recheck` old, so another process's publish or remove is seen within that;
  // manifests are cached per version. While the store is known to be down (StoreUnavailable::
  // known_down), the last reading is returned if there is one (and trusted for another
  // `recheck`); other failures to read the store are thrown.
  std::shared_ptr<const ImageEntry> find(const std::string& id) const;

  // Whether images/ID exists, whatever it points to: find() is null for a published image whose
  // version or manifest is missing or damaged, and such an image can still be removed.
  bool published(const std::string& id) const;

  // How many ids are published (damaged ones included): one listing, no manifest read.
  std::size_t count() const;

  // Every published image that can be read, sorted by id.
  std::vector<std::shared_ptr<const ImageEntry>> list() const;

  // A new, empty folder to build an image in; give it to publish() or discard().
  std::string make_staging_dir() const;
  void discard(const std::string& staging_dir) const;

  // A staging folder holding every file of `from` but its manifest, as hard links, for an edit
  // that replaces a few small files (by writing new ones and renaming them over the links —
  // never writing through a link, which would change the published version too).
  std::string make_staging_copy(const ImageEntry& from) const;

  // Commits `staging_dir` (holding the pyramid; manifest.json is written here) as a new version
  // of m.id and points the id at it. Fills m.version and m.created_ms. The staging folder is
  // gone afterwards, whatever happened.
  //
  // With `expected_version`, publishing is conditional (optimistic concurrency for edits): if
  // the published version of m.id is no longer that one ("" for none) — another edit, a re-ingest
  // or a delete came first, in this process or another replica — VersionConflict is thrown. The
  // check is made before the version is stored, and again with the move of the pointer under
  // the id's lock across processes; a version that lost the second check stays unnamed (in
  // VersionConflict::stored) until the garbage collector's grace has passed.
  std::shared_ptr<const ImageEntry> publish(const std::string& staging_dir, Manifest m,
                                            const std::string* expected_version = nullptr);

  // The published version of `id` read from the store now, not remembered: what a conditional
  // publish will be compared with. Null when none.
  std::shared_ptr<const ImageEntry> find_now(const std::string& id) const;

  // Publishes `staging_dir` as the version `m` names, keeping m.version and m.created_ms: a
  // version copied from another store (`zoomwarp store copy`). Throws when the store holds that
  // version already.
  std::shared_ptr<const ImageEntry> import(const std::string& staging_dir, const Manifest& m);

  // Unpublishes `id`, even when its manifest is damaged; false if it was not published.
  bool remove(const std::string& id);

  // Removes versions no pointer names that are older than `grace`, and staging folders whose
  // process is gone (or that are older than a day). Returns how many it removed.
  int collect_garbage(std::chrono::seconds grace);

  // How many publishes and removes this process has made: a cache of what the store holds (the
  // IIIF collection's index) knows from it that this process changed the store. Other processes'
  // changes are seen within recheck(), as find()'s are.
  std::uint64_t generation() const;
  std::chrono::steady_clock::duration recheck() const { return recheck_; }

  // Why the store cannot be read now, or "" (readiness): given up on after `within`.
  std::string problem(std::chrono::milliseconds within) const;

  // Requests made to a remote store and what its cache holds (metrics); zero for a folder.
  StoreStats stats() const;

 private:
  // Reads the pointer of `id` now (no caching): the published version, or null.
  std::shared_ptr<const ImageEntry> read_link(const std::string& id) const;
  std::shared_ptr<const ImageEntry> load_version(const std::string& id,
                                                 const std::string& version_dir) const;
  // This process changed the pointer of `id`: forget its reading, and any reading in progress.
  void forget_link(const std::string& id);

  struct LinkReading {
    std::shared_ptr<const ImageEntry> entry;
    std::chrono::steady_clock::time_point read_at;
  };

  std::unique_ptr<StoreBackend> backend_;
  std::chrono::steady_clock::duration recheck_;
  mutable std::shared_mutex links_mu_;
  // Published ids as last read (entries leave when an id is found unpublished); generation_ counts
  // forget_link() calls, so that a reading begun before one is not remembered after it.
  mutable std::unordered_map<std::string, LinkReading> links_;
  mutable std::uint64_t generation_ = 0;
  mutable std::mutex mu_;
  mutable std::unordered_map<std::string, std::shared_ptr<const ImageEntry>> versions_;
};

}  // namespace zoomwarp::tiles
