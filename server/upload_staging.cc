#include "server/upload_staging.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <nlohmann/json.hpp>
#include <utility>

#include "api/errors.h"
#include "server/log.h"
#include "tiles/header_sniff.h"

namespace zoomwarp::server {

namespace {
// Any failure to stage: the detail (it may name a path) goes to the log, the client gets a 503.
api::Response cannot_stage(const std::string& error) {
  log_event("error", "cannot stage an upload", {{"error", error}});
  return api::error_response(503, "store_unavailable", "the upload cannot be stored now");
}
}  // namespace

// The folder goes before the slot (slot_'s own destructor, after this body): once an upload is
// admitted in its place, the bytes it reserved (--max-staging) are free on disk too.
UploadStaging::~UploadStaging() {
  if (fd_ >= 0) ::close(fd_);
  if (!dir_.empty()) context_.store.discard(dir_);
}

std::optional<api::Response> UploadStaging::admit(const api::Request& req,
                                                  std::optional<std::uint64_t> content_length) {
  const std::uint64_t bytes = content_length.value_or(context_.max_upload_bytes);
  slot_ = context_.slots.try_admit(bytes);
  if (!slot_) {
    api::Response r = api::error_response(503, "ingest_busy", "the server is ingesting as many uploads as it can; retry shortly");
    r.set_header("Retry-After", "1");
    r.route = "overloaded";
    return r;
  }
  if (auto refusal = rate_limit(req, bytes)) {
    slot_.reset();
    return refusal;
  }
  held_.resize(tiles::kHeaderSniffBytes);
  return std::nullopt;
}

// --upload-rate and --upload-bytes-per-day: a request with a valid key is counted against its key
// wherever it comes from, one without against its client address. The upload is counted from the
// header (Content-Length; a chunked one as --max-upload), so it is refused before its body is read.
std::optional<api::Response> UploadStaging::rate_limit(const api::Request& req, std::uint64_t bytes) {
  std::string key_id;  // "" for no valid key: metrics count those together, never per address
  if (context_.keys && !req.authorization.empty()) {
    const auto result = context_.keys->authenticate(req.authorization);
    if (result.outcome == api::Authenticator::Outcome::kValid) key_id = result.principal.key_id;
  }
  const std::string client = key_id.empty() ? "address:" + req.client_address : "key:" + key_id;
  const auto refusal = context_.rate_limits.admit(client, bytes, std::chrono::steady_clock::now());
  if (!refusal) {
    context_.metrics.observe_upload(key_id);
    return std::nullopt;
  }
  context_.metrics.observe_rate_limited(key_id, std::string(refusal->limit));
  api::Response r = api::error_response(
      429, "rate_limited",
      std::string(refusal->limit == "bytes_per_day" ? "over the upload bytes per day" : "over the uploads per minute") +
          " allowed to " + (key_id.empty() ? "this address" : "this key") + "; retry after " +
          std::to_string(refusal->retry_after_seconds) + " s");
  r.set_header("Retry-After", std::to_string(refusal->retry_after_seconds));
  r.route = "rate_limited";
  return r;
}

std::span<std::uint8_t> UploadStaging::space() { return std::span(held_).subspan(filled_); }

// Until the first kHeaderSniffBytes (or the whole body) are in, nothing is written: they are
// checked first, and a refused upload leaves no file behind and is not read on.
std::optional<api::Response> UploadStaging::add(std::size_t n, bool whole_body) {
  filled_ += n;
  if (fd_ < 0) {
    if (!whole_body && filled_ < held_.size()) return std::nullopt;  // the first piece is not all here
    if (filled_ == 0) return std::nullopt;  // an empty body: nothing to stage, the router says what is wrong
    if (auto refusal = refuse_head(whole_body)) return refusal;
    if (auto refusal = open_file()) return refusal;
  }
  for (std::size_t written = 0; written < filled_;) {
    const ssize_t w = ::write(fd_, held_.data() + written, filled_ - written);
    if (w < 0 && errno == EINTR) continue;
    if (w < 0) return cannot_stage(std::strerror(errno));
    written += std::size_t(w);
  }
  filled_ = 0;
  return std::nullopt;
}

std::optional<api::Response> UploadStaging::finish() {
  if (fd_ < 0) return std::nullopt;
  if (::close(std::exchange(fd_, -1)) != 0) return cannot_stage(std::strerror(errno));
  return std::nullopt;
}

// 415 for a format ingest does not read, 422 for a header that cannot be right, 413 for a size
// over the ingest limits — the same answers ingest would give, without the body.
std::optional<api::Response> UploadStaging::refuse_head(bool whole_body) const {
  using Status = tiles::SniffedHeader::Status;
  const tiles::SniffedHeader h = tiles::sniff_image_header(held_.data(), filled_);
  const tiles::SourceLimits& limits = context_.limits;
  switch (h.status) {
    case Status::kUnknownFormat:
      return api::error_response(415, "unsupported_format", "the upload is not a JPEG, PNG, TIFF, WebP, JPEG 2000, HEIF or AVIF image");
    case Status::kCorrupt:
      return api::error_response(422, "corrupt_image", "the image header is unreadable: " + h.problem);
    case Status::kIncomplete:
      if (whole_body) return api::error_response(422, "corrupt_image", "the image ends inside its header");
      return std::nullopt;  // the decoder at ingest reads on and decides
    case Status::kOk:
      break;
  }
  const auto max_side = std::uint64_t(limits.max_dimension);
  if (h.width > max_side || h.height > max_side || h.width * h.height > limits.max_pixels)
    return api::error_response(413, "image_too_large",
                               "the image is " + std::to_string(h.width) + "x" + std::to_string(h.height) +
                                   " pixels; the limits are " + std::to_string(limits.max_pixels) + " pixels and " +
                                   std::to_string(max_side) + " per side");
  return std::nullopt;
}

std::optional<api::Response> UploadStaging::open_file() {
  try {
    dir_ = context_.store.make_staging_dir();
  } catch (const std::exception& e) {
    return cannot_stage(e.what());
  }
  const std::string path = dir_ + "/upload";
  fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd_ < 0) return cannot_stage(std::strerror(errno));
  file_ = path;
  return std::nullopt;
}

}  // namespace zoomwarp::server
