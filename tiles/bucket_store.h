// A Store's images in a bucket of an S3-compatible object store (issue 29), under a key prefix:
//
//   PREFIX/images/ID                      the pointer: an object holding "ID@VERSION"
//   PREFIX/versions/ID@VERSION/…          one immutable version: level_K.tif, analyses, manifest.json
//   PREFIX/superseded/ID@VERSION          when VERSION stopped being published
//   PREFIX/locks/ID                       the lease of the replica moving images/ID now
//
// What it relies on: S3's strong read-after-write consistency (AWS since December 2020; Swift,
// MinIO and Ceph RGW for a single object): a pointer PUT is seen by every reader's next GET, and
// an object is all there or not there. A commit uploads every file of the version, manifest.json
// last, and only then writes the pointer, so a reader sees the old version or the new one; a cut
// commit leaves objects no pointer names, which collect_garbage() removes after the grace period
// (their age is in their name: a version's first 11 hex digits are its creation time in ms).
//
// Reads: a version's files are read by byte range (RandomAccessFile), in blocks kept in a
// RangeCache (memory, and a bounded local folder if asked for): a level's TIFF header and tile
// index are read once, then a tile costs one ranged GET. A file's size is one HEAD the first time.
// Small files (manifest, analyses) are read whole and cached the same way. A store that is down
// or slow is StoreUnavailable (store_errors.h) within the thread's deadline (store_deadline.h).
//
// Local state: staging folders in `local_dir`/staging (a version is built on local disk, as for a
// folder store, then uploaded).
//
// Locking (issue 42): lock_id() is a lease, PREFIX/locks/ID (bucket_lease.h), taken after this
// process's own mutex for the id, so that an edit's check of the published version and its move
// of the pointer are one step for every replica sharing the bucket: of two edits made against one
// version, one wins and the other is a VersionConflict, on every S3-compatible store (plain GET,
// PUT and DELETE of one key; no conditional writes, which Swift's s3api lacks). Only the pointer
// move is under the lease: a version's files are uploaded before it is taken.
#pragma once

#include <memory>
#include <string>

#include "tiles/bucket_lease.h"
#include "tiles/range_cache.h"
#include "tiles/s3_client.h"
#include "tiles/store_backend.h"

namespace zoomwarp::tiles {

// `client` is shared: its connections, counters and retries serve every version's files.
std::unique_ptr<StoreBackend> bucket_store(const S3Location& where, std::shared_ptr<S3Client> client,
                                           const std::string& local_dir, const RangeCacheOptions& cache,
                                           const LeaseTiming& lease);

}  // namespace zoomwarp::tiles
