// A client for S3-compatible object stores (issue 29): the few operations the image store and
// `zoomwarp store copy` need, each bounded by the caller's deadline, retried where retrying can
// help, and counted.
//
//   get / get_range / head    an object, a byte range of it, its size and ETag; nullopt when the
//                             key does not exist
//   put / put_file            an object from memory, or streamed from a file of any size
//                             (a multipart upload past S3ClientOptions::multipart_threshold)
//   copy                      an object to another key, inside the store
//   remove                    a key, present or not
//   list                      one ListObjectsV2 page: keys under a prefix, grouped by a delimiter
//   create_bucket             for tests and for copying a store into a new bucket
//
// Requests are signed by libcurl (CURLOPT_AWS_SIGV4, "aws:amz:REGION:s3"), not by code of ours.
// libcurl 7.88 neither sends x-amz-content-sha256 nor hashes a streamed body, and S3 (and
// Swift's s3api) refuse a request without that header; so it is always sent, and libcurl signs
// with its value: the SHA-256 of the body (of nothing for GET, HEAD and DELETE). The access key
// goes to libcurl as a user name of its own (CURLOPT_USERNAME), since keys may hold a ':'
// (Swift's "account:user"). Paths and queries are written already canonical (s3_config.h): libcurl
// signs them as written, and a query out of order is a SignatureDoesNotMatch.
//
// Connections are reused: each request borrows an easy handle from a pool, and a handle keeps its
// connections open between requests; the last handle returned is the first lent (a warm
// connection), and handles beyond `max_idle_handles` are closed when returned. DNS answers and TLS
// sessions are shared between handles through a CURLSH with a lock per kind of data; connections
// are not, because libcurl does not support sharing its connection cache between threads that
// run transfers concurrently (CURLSHOPT_SHARE(3)).
//
// Deadlines: every operation takes a steady-clock deadline and returns or throws by it (within
// libcurl's timer, a few milliseconds), whatever the server does: each attempt's libcurl timeout (connect and total) is the time left, a transfer
// slower than `low_speed_bytes_per_second` for `low_speed_time` is abandoned (a server that
// accepted the connection and then hung, e.g. SIGSTOPped), and no backoff sleeps past the
// deadline. A deadline already past throws at once, before any request.
//
// Retries: a failure to connect or resolve, a timeout or stalled transfer, a connection cut
// mid-answer, and the answers 500, 502, 503 (SlowDown), 504, 408 and 429 are retried, up to
// `max_attempts` attempts in all, after a sleep drawn uniformly from [0, min(max_backoff,
// base_backoff · 2^(attempt-1))] ("full jitter": clients throttled together do not return
// together) — or, when the answer carries Retry-After (delta-seconds), at least that long, and
// none at all (the failure thrown at once) when that is past the deadline. Other answers (4xx, 501) are final at once: they would only be answered the same
// again. Every operation is idempotent (a put replaces, a remove of a missing key succeeds,
// creating a bucket that exists and is ours is not an error), so a retry after a lost answer is
// harmless. A body
// streamed from a file is rewound for each attempt, and when libcurl itself resends a request on
// a reused connection the server had closed (CURLOPT_SEEKFUNCTION).
//
// Arguments: a bucket name that valid_bucket_name accepts and a key of 1-1024 bytes (a prefix may
// be empty), else std::invalid_argument before any request.
//
// Errors are S3Error: the HTTP status, S3's error Code and Message from the XML body, the
// operation, bucket and key, and whether the store was unreachable or out of time (unavailable(),
// timed_out()), which callers answer with 503 and 504; refused credentials say so in what().
//
// Threads: every member may be called from any thread concurrently (the handle pool is under a
// mutex held only to take or return a handle; counters are atomics). Construct one client per
// configuration and share it.
#pragma once

#include <array>
#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "tiles/s3_config.h"

namespace zoomwarp::tiles {

using S3Deadline = std::chrono::steady_clock::time_point;

enum class S3Operation : int { kGet, kGetRange, kHead, kPut, kPutFile, kRemove, kList, kCreateBucket, kCopy };
inline constexpr std::size_t kS3OperationCount = 9;
// "get", "get_range", "head", "put", "put_file", "remove", "list", "create_bucket", "copy".
const char* s3_operation_name(S3Operation op);

class S3Error : public std::runtime_error {
 public:
  struct Details {
    S3Operation operation = S3Operation::kGet;
    std::string bucket;
    std::string key;         // the key, or the prefix for list; empty for create_bucket
    int status = 0;          // the last answer's HTTP status; 0 when none came (no connection, timeout)
    std::string code;        // S3's <Code> (NoSuchBucket, SignatureDoesNotMatch, SlowDown…); may be empty
    std::string message;     // S3's <Message>, or what libcurl or this client found wrong
    std::string request_id;  // x-amz-request-id, for the store's operators
    int attempts = 0;        // requests made for this operation
    // The store could not be reached or did not answer in time, or kept failing (5xx, throttling)
    // until the attempts or the deadline ran out: a caller answers 503 (504 when timed_out).
    bool unavailable = false;
    // The last attempt ran out of time (the deadline, or the low-speed limit), or the deadline had
    // passed before the first. (Refused connections until the deadline are unavailable but not
    // timed out: the store is down, not slow.)
    bool timed_out = false;
  };

  explicit S3Error(Details d);

  const Details& details() const { return d_; }
  int status() const { return d_.status; }
  const std::string& code() const { return d_.code; }
  bool unavailable() const { return d_.unavailable; }
  bool timed_out() const { return d_.timed_out; }
  // 403 for the credentials themselves (unknown key, wrong secret, expired token), not for a
  // permission the credentials lack (AccessDenied).
  bool credentials_refused() const;

 private:
  Details d_;
};

struct S3ObjectInfo {
  std::uint64_t size = 0;
  std::string etag;          // without its quotes (for a single-part upload, the body's MD5 in hex)
  std::string content_type;
};

struct S3ListEntry {
  std::string key;
  std::uint64_t size = 0;
  std::string etag;  // without its quotes
};

// One page of ListObjectsV2, keys in the store's order (UTF-8 binary order on AWS).
struct S3ListPage {
  std::vector<S3ListEntry> objects;
  std::vector<std::string> common_prefixes;  // with a delimiter: each "directory" once, delimiter included
  bool truncated = false;                    // more keys follow: ask again with next_continuation
  std::string next_continuation;
};

struct S3ClientOptions {
  int max_attempts = 5;                                   // requests per operation at most (≥ 1)
  std::chrono::milliseconds base_backoff{50};
  std::chrono::milliseconds max_backoff{2000};
  std::chrono::milliseconds connect_timeout{3000};        // at most, within the deadline
  long low_speed_bytes_per_second = 1024;                 // slower than this…
  std::chrono::seconds low_speed_time{10};                // …for this long: the attempt fails
  std::size_t max_idle_handles = 32;                      // pooled easy handles (their connections) kept
  // put_file of a larger file is a multipart upload (one PUT is at most 5 GiB on AWS), in parts
  // of this many bytes (at least 5 MiB, S3's smallest part; at most 10 000 parts), each read into
  // memory, hashed and sent, retried on its own.
  std::uint64_t multipart_threshold = 1ull << 30;
  std::uint64_t multipart_part_bytes = 64ull << 20;
};

// What the client did since it was made, for metrics and cost reports (S3 bills per request and
// per byte out). Requests count attempts: a retried operation costs several.
struct S3Stats {
  std::array<std::uint64_t, kS3OperationCount> requests{};  // indexed by S3Operation
  std::array<std::uint64_t, kS3OperationCount> failures{};  // operations that threw S3Error
  std::uint64_t retries = 0;         // attempts after the first
  std::uint64_t bytes_sent = 0;      // request bodies (uploads), retries included
  std::uint64_t bytes_received = 0;  // response bodies (downloads, listings, error documents)
};

class S3Client {
 public:
  // Initialises libcurl once per process (curl_global_init; Debian's 7.88 is built thread-safe).
  // Makes no request: a store that is down or credentials that are wrong show on the first call.
  explicit S3Client(S3Config config, S3ClientOptions options = {});
  ~S3Client();
  S3Client(const S3Client&) = delete;
  S3Client& operator=(const S3Client&) = delete;

  const S3Config& config() const;

  // The whole object, or nullopt if the key does not exist (404 NoSuchKey). A missing bucket is
  // an S3Error (404 NoSuchBucket): a store misconfigured, not an image missing.
  std::optional<std::string> get(std::string_view bucket, std::string_view key, S3Deadline deadline);

  // Exactly bytes [offset, offset + length) of the object (length ≥ 1, else
  // std::invalid_argument), or nullopt if the key does not exist. A range not wholly inside the
  // object is an S3Error (416 InvalidRange, or status 206 and code "ShortRange" when the store
  // sent fewer bytes), as is a store that ignores the range and answers 200 with the whole object
  // (code "RangeIgnored"; the transfer is cut at once, not read to its end).
  std::optional<std::string> get_range(std::string_view bucket, std::string_view key, std::uint64_t offset,
                                       std::uint64_t length, S3Deadline deadline);

  // Size, ETag and type, or nullopt on 404. A HEAD answer has no body to tell a missing key from a
  // missing bucket: both are nullopt here.
  std::optional<S3ObjectInfo> head(std::string_view bucket, std::string_view key, S3Deadline deadline);

  // Stores `body` under `key` (replacing it), with x-amz-content-sha256 its SHA-256: the store
  // checks the bytes it received. Returns the new ETag (without quotes).
  std::string put(std::string_view bucket, std::string_view key, std::string_view body,
                  std::string_view content_type, S3Deadline deadline);

  // Stores the file at `path`, streamed (a read callback; never held in memory whole). The body is
  // signed with its SHA-256, like put: `sha256_hex` when the caller has it (store copy hashes what
  // it copies anyway), else the file is read once more first to hash it. Why not UNSIGNED-PAYLOAD,
  // which would spare that read: over plain http (an in-cluster MinIO, the tests' Swift) nothing
  // else checks the bytes, and a file changed between the hash and the upload, or between two
  // attempts, is refused by the store (400 XAmzContentSHA256Mismatch; BadDigest from Swift)
  // instead of stored half old.
  // A file over S3ClientOptions::multipart_threshold goes up as a multipart upload (Create, one
  // UploadPart per part signed with the part's SHA-256, Complete; Abort when any of it fails), so
  // a level file may be over the 5 GiB one PUT is limited to on AWS.
  // The file must not grow or shrink during the call. Throws std::system_error when the file cannot
  // be opened or read. Returns the new ETag (a multipart upload's is not the file's MD5).
  std::string put_file(std::string_view bucket, std::string_view key, const std::string& path,
                       std::string_view content_type, S3Deadline deadline, std::string_view sha256_hex = {});

  // Copies `from_key` to `to_key` in `bucket` inside the store (CopyObject: no bytes pass through
  // this process), content type and all. The source must be at most 5 GiB (S3's limit for one
  // copy). Returns the copy's ETag. A missing source is an S3Error (404 NoSuchKey).
  std::string copy(std::string_view bucket, std::string_view from_key, std::string_view to_key, S3Deadline deadline);

  // Deletes `key`. A key already missing is success: S3 answers 204 either way, and other stores'
  // 404 NoSuchKey (as a retry whose first answer was lost would also see) means the same — it is
  // gone. A missing bucket (404 NoSuchBucket) is an S3Error.
  void remove(std::string_view bucket, std::string_view key, S3Deadline deadline);

  // One ListObjectsV2 page of the keys starting with `prefix` (empty: all). With a `delimiter`
  // (usually "/"), keys holding it after the prefix are rolled up into common_prefixes.
  // `continuation`: empty for the first page, then the previous page's next_continuation.
  // `max_keys` (1–1000) bounds the page; stores may return fewer. Keys are asked for URL-encoded
  // (encoding-type=url) and decoded here, so any key survives the XML.
  S3ListPage list(std::string_view bucket, std::string_view prefix, std::string_view delimiter,
                  std::string_view continuation, S3Deadline deadline, int max_keys = 1000);

  // Creates `bucket` in the configured region. Returns false when it exists already and is ours
  // (409 BucketAlreadyOwnedByYou); a bucket someone else owns is an S3Error (409
  // BucketAlreadyExists). Throws std::invalid_argument for an invalid name (valid_bucket_name).
  bool create_bucket(std::string_view bucket, S3Deadline deadline);

  // A snapshot of the counters (each read atomically; not one instant across them).
  S3Stats stats() const;

 private:
  std::string put_multipart(std::string_view bucket, std::string_view key, int fd, std::uint64_t size,
                            std::string_view content_type, S3Deadline deadline);

  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace zoomwarp::tiles
