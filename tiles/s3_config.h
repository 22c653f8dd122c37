// Where an S3-compatible object store is and how to sign for it (issue 29): the credentials,
// region and endpoint, read from the standard AWS environment as the AWS CLI and SDKs read them,
// and `s3://BUCKET/PREFIX` store locations. No I/O here: tiles/s3_client.h makes the requests.
//
//   AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY   the keys; or a shared credentials file, a web
//   AWS_SESSION_TOKEN                          identity or a container endpoint, renewed before
//                                              they expire (s3_credentials.h); a session token
//                                              is sent as x-amz-security-token
//   AWS_REGION (else AWS_DEFAULT_REGION)       default us-east-1; what requests are signed for
//   AWS_ENDPOINT_URL_S3 (else AWS_ENDPOINT_URL) optional: an S3-compatible store (MinIO, Ceph
//                                              RGW, Swift's s3api, R2) at scheme://host[:port]
//
// An empty variable counts as unset, as in the AWS tools. Addressing: with an endpoint, path-style
// (ENDPOINT/BUCKET/KEY): what every compatible store accepts, and no wildcard DNS or certificate
// needed for the bucket. Without one, AWS virtual-hosted style
// (https://BUCKET.s3.REGION.amazonaws.com/KEY), which AWS prefers; a bucket name with a dot is
// addressed path-style there (https://s3.REGION.amazonaws.com/BUCKET/KEY), since the wildcard
// certificate *.s3.REGION.amazonaws.com does not cover it.
//
// Object keys go into URLs percent-encoded as SigV4 canonicalises them (RFC 3986 unreserved
// characters and '/' kept, every other byte %XX in upper case): libcurl signs the path and query
// exactly as written, so the written form must already be the canonical one.
//
// Threads: S3Config and S3Location are immutable values (the credential source they share is
// thread-safe); any thread may use them.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "tiles/s3_credentials.h"

namespace zoomwarp::tiles {

// A configuration that cannot work: credentials missing, a malformed endpoint, region, bucket or
// s3:// location. The message names the variable or value at fault (never a secret's value).
struct S3ConfigError : std::invalid_argument {
  using std::invalid_argument::invalid_argument;
};

class S3Config {
 public:
  static constexpr const char* kDefaultRegion = "us-east-1";

  // Explicit values (tests, tools). `endpoint` empty: AWS itself. Throws S3ConfigError for an
  // empty access key or secret, a region that is not [a-z0-9-]+, an endpoint that is not
  // http(s)://host[:port] (a trailing '/' is dropped), or a line break in any value.
  S3Config(std::string access_key_id, std::string secret_access_key,
           std::string region = kDefaultRegion, std::string endpoint = {},
           std::string session_token = {});

  // Any credential source (s3_credentials.h), with the region and endpoint as above.
  S3Config(std::shared_ptr<S3CredentialSource> credentials, std::string region = kDefaultRegion,
           std::string endpoint = {});

  // From the process environment (table above). Throws S3ConfigError when no credentials are
  // configured, or naming the variable whose value is malformed.
  static S3Config from_environment();
  // The same from any lookup (tests): `lookup(NAME)` is the variable's value, or nullopt.
  static S3Config from_environment(
      const std::function<std::optional<std::string>(const char* name)>& lookup);

  // The credentials to sign the next request with (S3CredentialSource::current: may renew them;
  // throws S3CredentialsError), and where they come from.
  S3Credentials credentials() const { return credentials_->current(); }
  S3CredentialSource& credential_source() const { return *credentials_; }
  const std::string& region() const { return region_; }
  // "scheme://host[:port]" without a trailing slash, or empty for AWS.
  const std::string& endpoint() const { return endpoint_; }
  bool path_style() const { return !endpoint_.empty(); }

  // The URL of `key` in `bucket` (key empty: the bucket itself), the key percent-encoded with
  // s3_uri_encode (slashes kept); `query`, when not empty, is appended after '?' as given: it
  // must already be canonical (sorted by name, names and values encoded with s3_uri_encode).
  std::string url(std::string_view bucket, std::string_view key, std::string_view query = {}) const;

  // "http://127.0.0.1:9000 (path-style, us-east-1)" or "AWS S3 (eu-west-1)": for logs and error
  // messages. Never holds a credential.
  std::string describe() const;

 private:
  std::shared_ptr<S3CredentialSource> credentials_;
  std::string region_;
  std::string endpoint_;
};

// A store's place in a bucket: `s3://BUCKET/PREFIX`.
struct S3Location {
  std::string bucket;
  // Empty, or ends with '/' and does not start with one: every key of the store is prefix + name.
  std::string prefix;

  // "s3://BUCKET/PREFIX" back (parse_s3_location(l.url()) == l).
  std::string url() const;
  bool operator==(const S3Location&) const = default;
};

// Parses `s3://BUCKET[/PREFIX]`. The bucket must satisfy valid_bucket_name; the prefix is
// normalised: leading slashes dropped, a trailing slash added when it is not empty
// ("s3://b//imgs" and "s3://b/imgs/" both give prefix "imgs/"). Throws S3ConfigError for another
// scheme, an invalid bucket name, or control characters in the prefix (XML 1.0, which S3's
// listings are written in, cannot carry most of them).
S3Location parse_s3_location(std::string_view url);

// AWS's rules for general-purpose bucket names, which also keep them valid DNS names for
// virtual-hosted addressing: 3–63 characters of a-z 0-9 . -, starting and ending with a letter or
// digit, no "..", ".-" or "-.", not an IPv4 address, not starting with "xn--" or "sthree-", not
// ending with "-s3alias" or "--ol-s3".
bool valid_bucket_name(std::string_view bucket);

// SigV4's URI encoding: A-Z a-z 0-9 - . _ ~ kept, '/' kept when `keep_slash`, every other byte
// (UTF-8 bytes included) as %XX with upper-case hex digits.
std::string s3_uri_encode(std::string_view s, bool keep_slash);

}  // namespace zoomwarp::tiles
