// Which published image a read request may see. A private image (tiles::Manifest::is_private) is
// readable only with a curator (or admin) key or a validly signed URL (api/url_signing.h);
// otherwise it answers 404 image_not_found exactly as an image that does not exist, so its
// existence is not revealed, and 403 url_expired / bad_signature for a signed URL that fails.
// Every read route asks here before its ETag check and cache lookup (api/cached_responses.h), so
// a cached answer is never served around the check.
//
// Thread safety: every member may be called from any thread at once (the store, the key ring and
// the signer are thread-safe).
#pragma once

#include <memory>
#include <string>
#include <utility>

#include "api/authorize.h"
#include "api/http_types.h"
#include "api/url_signing.h"
#include "tiles/store.h"

namespace zoomwarp::api {

class ImageAccess {
 public:
  // `signer` null: no signed URL and no service token is valid (no --signing-key).
  ImageAccess(const tiles::Store& store, const AccessPolicy& access, std::shared_ptr<const UrlSigner> signer)
      : store_(store), access_(access), signer_(std::move(signer)) {}

  // Whether the request carries a valid curator (or admin) key.
  bool has_curator_key(const Request& req) const;

  // The image `id` for reading, like find_image() (api/responses.h), under the rule above.
  std::shared_ptr<const tiles::ImageEntry> readable_image(const Request& req, const std::string& id) const;

  // The image of an IIIF Image service segment: readable_image() for a plain id; for a service
  // segment ID~EXPIRES~SIG (a private manifest's service token, api/url_signing.h) the image when
  // the token is valid, 403 url_expired / bad_signature when not.
  std::shared_ptr<const tiles::ImageEntry> readable_service(const Request& req, const std::string& segment) const;

 private:
  const tiles::Store& store_;
  const AccessPolicy& access_;
  std::shared_ptr<const UrlSigner> signer_;
};

}  // namespace zoomwarp::api
