// One upload's way from its request header to a staging file, without the socket: the session
// (session.h) reads the body in pieces and hands each one here, which decides what becomes of it.
//
//   1. admit(), right after the header: an ingest slot (upload_admission.h; none free: 503
//      ingest_busy), then the upload rate limits (api/rate_limits.h; over: 429), both with
//      Retry-After, so a refused upload's body is never read.
//   2. space() and add() for each piece of the body: the first tiles::kHeaderSniffBytes (or the
//      whole body, if shorter) are held in memory and sniffed (tiles/header_sniff.h: 415, 422,
//      413) before a staging folder is made (Store::make_staging_dir()) and anything written;
//      later pieces are appended to the file.
//   3. finish() closes the file, which file() names for the ingest (api::Request::body_file).
//
// Destroying an UploadStaging removes its staging folder and gives its slot back: the session does
// so once the upload is answered (after its ingest) or its client is gone. Every refusal is the
// response to send; the rest of the body is not read, so the session closes the connection after it.
//
// Threads: an UploadStaging belongs to one session and is used on that session's thread. What an
// UploadContext refers to is shared by all sessions and thread-safe.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "api/access.h"
#include "api/http_types.h"
#include "api/rate_limits.h"
#include "server/metrics.h"
#include "server/upload_admission.h"
#include "tiles/pyramid_builder.h"
#include "tiles/store.h"

namespace zoomwarp::server {

// What every upload is admitted, counted and staged by. The referenced objects outlive the uploads.
struct UploadContext {
  tiles::Store& store;              // the staging folders are its own, so an ingest can publish them
  UploadAdmission& slots;
  api::RateLimits& rate_limits;     // per "key:ID" for a valid key, else per "address:IP"
  Metrics& metrics;                 // uploads admitted and refused by the rate limits, by key id
  const api::Authenticator* keys;   // null: no keys, every upload counts against its address
  const tiles::SourceLimits& limits;  // ingest's: a sniffed size over them is refused at once
  std::uint64_t max_upload_bytes;   // what an upload without Content-Length (chunked) is taken for
};

class UploadStaging {
 public:
  explicit UploadStaging(const UploadContext& context) : context_(context) {}
  ~UploadStaging();
  UploadStaging(const UploadStaging&) = delete;
  UploadStaging& operator=(const UploadStaging&) = delete;

  // Admits the upload `req` announces (its Authorization and client_address are read), holding a
  // slot until destruction; nullopt if admitted. Else the 503 or 429 answer, and nothing is held.
  // Call once, before anything else.
  std::optional<api::Response> admit(const api::Request& req, std::optional<std::uint64_t> content_length);

  // Where the body's next bytes go; never empty while the body is being read.
  std::span<std::uint8_t> space();
  // `n` bytes were read into space(); `whole_body`: the body ends with them. nullopt: read on (or
  // finish()). Else the refusal (415, 422, 413, or 503 store_unavailable when the staging folder
  // or file cannot be made or written).
  std::optional<api::Response> add(std::size_t n, bool whole_body);
  // After the body's last add(): closes the file. nullopt, or 503 store_unavailable.
  std::optional<api::Response> finish();

  // The staged body, for api::Request::body_file; "" while none is staged (an empty body).
  const std::string& file() const { return file_; }

 private:
  std::optional<api::Response> rate_limit(const api::Request& req, std::uint64_t bytes);
  std::optional<api::Response> refuse_head(bool whole_body) const;
  std::optional<api::Response> open_file();

  const UploadContext context_;
  UploadAdmission::Slot slot_;
  // The body's bytes not yet written: its first piece waits here until it is sniffed, later ones
  // are written as soon as they arrive.
  std::vector<std::uint8_t> held_;
  std::size_t filled_ = 0;  // bytes of held_ holding body
  std::string dir_;         // the staging folder, once made
  std::string file_;        // dir_ + "/upload"
  int fd_ = -1;             // file_, open for writing until finish()
};

}  // namespace zoomwarp::server
