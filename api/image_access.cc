#include "api/image_access.h"

#include <chrono>
#include <utility>

#include "api/errors.h"
#include "api/responses.h"

namespace zoomwarp::api {

namespace {

// A signed URL's or service token's verdict, other than kUnsigned: 403 unless it is valid.
void refuse_unless_valid(UrlSigner::Verdict verdict) {
  using Verdict = UrlSigner::Verdict;
  if (verdict == Verdict::kExpired) throw ApiError(403, "url_expired", "this signed URL has expired; ask for a new one");
  if (verdict != Verdict::kValid)
    throw ApiError(403, "bad_signature", "the signature does not match this URL (path, query and expiry are signed)");
}

}  // namespace

bool ImageAccess::has_curator_key(const Request& req) const {
  const Authenticator* keys = access_.keys;
  if (!keys || req.authorization.empty()) return false;
  const auto result = keys->authenticate(req.authorization);
  return result.outcome == Authenticator::Outcome::kValid && result.principal.role >= Role::kCurator;
}

std::shared_ptr<const tiles::ImageEntry> ImageAccess::readable_image(const Request& req, const std::string& id) const {
  auto entry = find_image(store_, id);
  if (!entry->manifest.is_private || has_curator_key(req)) return entry;
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
  using Verdict = UrlSigner::Verdict;
  const Verdict verdict = signer_ ? signer_->verify(req.path, req.query, now.count()) : Verdict::kUnsigned;
  if (verdict != Verdict::kUnsigned) {
    refuse_unless_valid(verdict);
    return entry;
  }
  // The same answer as for an id that does not exist (responses.cc find_image).
  throw ApiError(404, "image_not_found", "no image with id '" + id + "'");
}

std::shared_ptr<const tiles::ImageEntry> ImageAccess::readable_service(const Request& req, const std::string& segment) const {
  const std::size_t tilde = segment.find('~');
  if (tilde == std::string::npos) return readable_image(req, segment);
  std::string id = segment.substr(0, tilde);
  check_image_id(id);
  if (!signer_) throw ApiError(403, "bad_signature", "this server has no signing key, so no service token is valid");
  const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
  refuse_unless_valid(signer_->verify_service(segment, now.count(), &id));
  return find_image(store_, id);
}

}  // namespace zoomwarp::api
