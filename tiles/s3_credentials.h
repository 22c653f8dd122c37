// Where an S3 client's credentials come from (issue 42), asked before every request, so that
// credentials that expire — a pod's web identity, a container's task role, a rotated file — are
// renewed before they do, as the AWS SDKs' default chain renews them. The sources, looked for in
// the SDKs' order (credentials_from_environment):
//
//   1. AWS_ACCESS_KEY_ID, AWS_SECRET_ACCESS_KEY (AWS_SESSION_TOKEN): fixed for the process.
//   2. A shared credentials file: AWS_SHARED_CREDENTIALS_FILE, else ~/.aws/credentials, profile
//      AWS_PROFILE (else "default"), keys aws_access_key_id, aws_secret_access_key,
//      aws_session_token. Read again when its modification time or size changes (looked at
//      once a second at most): a rotated file is used without a restart.
//   3. Web identity (Kubernetes IRSA, EKS and other OIDC federation): AWS_WEB_IDENTITY_TOKEN_FILE
//      and AWS_ROLE_ARN (AWS_ROLE_SESSION_NAME). The token file is read at every renewal (the
//      kubelet rotates it) and exchanged at STS (AssumeRoleWithWebIdentity, an unsigned POST) at
//      AWS_ENDPOINT_URL_STS, else AWS_ENDPOINT_URL, else https://sts.REGION.amazonaws.com.
//   4. The container credentials endpoint (ECS task roles, EKS Pod Identity):
//      AWS_CONTAINER_CREDENTIALS_FULL_URI, or http://169.254.170.2 + AWS_CONTAINER_CREDENTIALS_
//      RELATIVE_URI; an Authorization header from AWS_CONTAINER_AUTHORIZATION_TOKEN_FILE (read at
//      every renewal) or AWS_CONTAINER_AUTHORIZATION_TOKEN. It answers JSON.
//
// Renewal (3 and 4): credentials are renewed once half their lifetime, or all but 5 minutes of
// it, has passed, by the first request that finds them so; requests meanwhile sign with the ones
// still valid. A renewal that fails while they are valid is tried again a second later; once they
// have expired, a request fails with S3CredentialsError (the store is then unavailable: 503). The
// store refusing them (ExpiredToken and the like: S3Client reports it through refused()) renews
// them at the next request.
//
// Threads: every member may be called from any thread at once.
#pragma once

#include <chrono>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace zoomwarp::tiles {

struct S3Credentials {
  std::string access_key_id, secret_access_key, session_token;
  // When they stop working; none for keys that do not expire.
  std::optional<std::chrono::system_clock::time_point> expiration;
};

// No credentials can be had now: the source failed and what it gave before has expired.
struct S3CredentialsError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class S3CredentialSource {
 public:
  virtual ~S3CredentialSource() = default;
  // The credentials to sign the next request with (see above). Throws S3CredentialsError.
  virtual S3Credentials current() = 0;
  // The store refused `used` as expired or unknown: renew at the next current().
  virtual void refused(const S3Credentials& used) = 0;
  // Which source, for logs and errors ("environment", "web identity for ROLE_ARN"…); no secret.
  virtual std::string describe() const = 0;
};

// Keys given as they are (tests, tools, source 1).
std::shared_ptr<S3CredentialSource> fixed_credentials(S3Credentials credentials);

// The first source of the list above that is configured in `lookup` (an environment; "HOME" is
// looked up for ~). Nothing is fetched yet. Throws S3ConfigError (s3_config.h) when none is, or a
// variable is malformed; `region` is STS's default region.
std::shared_ptr<S3CredentialSource> credentials_from_environment(
    const std::function<std::optional<std::string>(const char* name)>& lookup, const std::string& region);

// The parts, for tests: STS's AssumeRoleWithWebIdentity answer, the container endpoint's JSON, a
// shared credentials file's profile, an ISO 8601 UTC time ("2026-12-08T01:02:03Z", fractions
// allowed). nullopt for what does not hold them.
std::optional<S3Credentials> parse_sts_credentials(std::string_view xml);
std::optional<S3Credentials> parse_container_credentials(std::string_view json);
std::optional<S3Credentials> parse_shared_credentials(std::string_view ini, std::string_view profile);
std::optional<std::chrono::system_clock::time_point> parse_utc_time(std::string_view iso8601);

}  // namespace zoomwarp::tiles
