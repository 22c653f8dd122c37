// Who is asking: the roles API keys carry, and the one question every route asks about a request
// — which key, if any, authenticated it. Keys come from the operator's key file (`--keys`); how
// they are read, hashed, compared and rotated is the key ring's business (api/key_ring.h).
//
// Threads: an Authenticator is called from every I/O and worker thread at once; implementations
// must be thread-safe.
#pragma once

#include <optional>
#include <string>
#include <string_view>

namespace zoomwarp::api {

// Ordered: a role may do everything the ones before it may.
//  - reader: reads what anyone may read; the key only identifies its holder (rate limits and
//    metrics per key);
//  - curator: also uploads, deletes, edits, and reads private images;
//  - admin: also metrics and operational details.
enum class Role { kReader = 0, kCurator = 1, kAdmin = 2 };

struct Principal {
  std::string key_id;  // the key's public name from the key file, never the key itself
  Role role = Role::kReader;
};

class Authenticator {
 public:
  virtual ~Authenticator() = default;

  enum class Outcome { kNoCredentials, kInvalid, kValid };
  struct Result {
    Outcome outcome = Outcome::kNoCredentials;
    Principal principal;  // set when kValid
  };

  // Judges an Authorization header value ("Bearer KEY"; empty: no credentials). Comparisons of
  // key material take the same time whether or not it matches.
  virtual Result authenticate(std::string_view authorization) const = 0;

  // Whether any key is configured at all (with none, nobody can authenticate).
  virtual bool has_keys() const = 0;
};

}  // namespace zoomwarp::api
