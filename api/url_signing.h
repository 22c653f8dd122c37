// Signed URLs for private images, in the style of imgproxy and S3 presigned URLs: whoever holds
// the server's signing secret (`--signing-key FILE`) can hand out a link to one private resource
// that works until it expires, without handing out an API key.
//
//   signed URL      PATH?QUERY&expires=UNIX_SECONDS&sig=HEX
//   signed string   PATH?QUERY&expires=UNIX_SECONDS   (the raw, still percent-encoded path and
//                   query as received, every parameter but `sig` in its received order)
//   sig             hex HMAC-SHA256(secret, signed string), lower case, 64 digits
//
// The method is not signed: a signed URL is for reading (GET/HEAD). Changing any byte of the path
// or query (another image, another view, a later expiry, a parameter added) breaks the signature.
//
// A service token signs one image's IIIF Image service as a whole: the service id inside a
// private image's manifest (api/presentation.h), which a viewer extends with /info.json and
// /{region}/{size}/{rotation}/{quality}.{format} and cannot keep a query string on. It stands in
// the path, in place of the image id:
//
//   service segment /iiif/3/ID~EXPIRES~SIG/…
//   signed string   iiif-image-service:ID~EXPIRES  (a URL's signed string starts with '/', so a
//                   signature of one kind never passes for the other)
//
// Image ids never hold '~', so a segment with one is a token or nothing.
//
// Threads: a UrlSigner is immutable after construction; all members may be called concurrently.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace zoomwarp::api {

// The query parameters a signature adds; every route accepts them (once) and they are not part of
// the view an ETag or cache key names.
bool is_signature_parameter(std::string_view name);

class UrlSigner {
 public:
  static constexpr std::size_t kMinSecretBytes = 32;

  // Throws std::invalid_argument if the secret is shorter than kMinSecretBytes.
  explicit UrlSigner(std::string secret);

  // Reads a secret file: hex digits (surrounding white space ignored; 64 or more), or else its raw
  // bytes. Throws std::runtime_error if it cannot be read or holds fewer than 32 bytes. The
  // message names the file, never its content.
  static UrlSigner from_file(const std::string& path);

  // `path` and `query` (without '?'; may be empty; any expires/sig in it are dropped) signed to be
  // valid until `expires` (Unix seconds). Returns PATH?QUERY&expires=…&sig=….
  std::string sign(std::string_view path, std::string_view query, std::int64_t expires) const;

  enum class Verdict { kUnsigned, kValid, kExpired, kBadSignature };
  // kUnsigned without a `sig` parameter. A wrong signature (compared in constant time), a missing
  // or malformed `expires` is kBadSignature; a right signature past its expiry (`now` > expires,
  // Unix seconds) is kExpired.
  Verdict verify(std::string_view path, std::string_view query, std::int64_t now) const;

  // The service segment ID~EXPIRES~SIG of image `id`, valid until `expires` (Unix seconds).
  std::string sign_service(std::string_view id, std::int64_t expires) const;

  // `segment` checked as a service segment: kUnsigned when it holds no '~' (a plain id, left in
  // *id), else the image id in *id and kValid, kExpired (`now` > EXPIRES) or kBadSignature (also
  // for a malformed token).
  Verdict verify_service(std::string_view segment, std::int64_t now, std::string* id) const;

 private:
  std::string secret_;
};

}  // namespace zoomwarp::api
