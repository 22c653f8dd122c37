// The operator's API keys (`--keys FILE`, `ZOOMWARP_KEYS`): an api::Authenticator that reads a
// key file, holds only the SHA-256 digests of its keys, and picks up a rewritten file without a
// restart.
//
// The key file, one key per line:
//
//   # KEY_ID   ROLE      KEY
//   alice      curator   kq3V0t1wKx8mYQ2p5lZr7A
//   ops        admin     sha256:9f86d081884c7d659a2feaa0c55ad015a3bf4f1b2b0b822cd15d6c15b0f00a08
//
//  - KEY_ID: 1-64 characters from A-Z a-z 0-9 . _ - ; unique in the file; the name logs and
//    metrics use (the key itself never appears in either);
//  - ROLE: reader, curator or admin (api/access.h);
//  - KEY: the key as clients send it (`Authorization: Bearer KEY`), at least 16 characters, no
//    white space; or `sha256:` and the 64 hex digits of its SHA-256 digest, so the file need not
//    hold the key itself (`zoomwarp keys new` prints both forms);
//  - fields are separated by spaces or tabs; `#` starts a comment line; blank lines are ignored.
//
// Rotation: the file is read again when its modification time, size or inode changed (looked at
// at most once a second, by authenticate()) and whenever reload() is called (the server calls it
// on SIGHUP). A file that does not parse on reload leaves the old keys in force and is reported
// through the log callback as an error; at construction it throws.
//
// Threads: authenticate(), has_keys() and reload() may be called from any threads at once; the
// keys are swapped as a whole under a mutex, so a request sees either the old keys or the new.
#pragma once

#include <array>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "api/access.h"

namespace zoomwarp::api {

using KeyDigest = std::array<unsigned char, 32>;  // SHA-256

struct KeyEntry {
  std::string key_id;
  Role role = Role::kReader;
  KeyDigest digest{};
};

// A key file that does not parse; the message names the line and what is wrong with it, never a
// key (a line's key field is not quoted back).
class KeyFileError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Parses the text of a key file (format above). Throws KeyFileError.
std::vector<KeyEntry> parse_key_file(std::string_view text);

// Whether `id` may name a key: 1-64 characters from A-Z a-z 0-9 . _ -
bool is_valid_key_id(std::string_view id);

// SHA-256 of `key`.
KeyDigest key_digest(std::string_view key);

// "reader", "curator", "admin"; and back (throws std::invalid_argument for another name).
std::string_view role_name(Role role);
Role parse_role(std::string_view name);

// A new random key (32 bytes from the OpenSSL CSPRNG, base64url without padding: 43 characters).
std::string random_key();

// Lowercase hex of a digest, as the `sha256:` form of the key file writes it.
std::string digest_hex(const KeyDigest& digest);

class KeyRing : public Authenticator {
 public:
  // level ("info", "error") and message; by default nothing is reported.
  using Log = std::function<void(std::string_view level, std::string_view message)>;

  // Reads `path`. Throws KeyFileError if it does not parse, std::runtime_error if it cannot be
  // read. A file with no keys at all is an error too: the operator meant to configure some.
  explicit KeyRing(std::string path, Log log = {});

  Result authenticate(std::string_view authorization) const override;
  bool has_keys() const override;

  // Reads the file again now. Returns false (and logs an error; the old keys stay) if it cannot
  // be read or does not parse.
  bool reload();

  // How many keys are in force.
  std::size_t size() const;

 private:
  struct FileStamp {
    std::int64_t mtime_ns = 0;
    std::uintmax_t size = 0;
    std::uint64_t inode = 0;
    bool operator==(const FileStamp&) const = default;
  };
  static FileStamp stamp_of(const std::string& path);
  std::shared_ptr<const std::vector<KeyEntry>> current_keys() const;  // after reload_if_changed()
  void reload_if_changed() const;
  bool load() const;  // the file as it is now; false: kept the old keys

  const std::string path_;
  const Log log_;
  // The keys are a cache of the file, refreshed from const authenticate(): hence mutable.
  mutable std::mutex mu_;
  mutable std::shared_ptr<const std::vector<KeyEntry>> keys_;  // guarded by mu_
  mutable FileStamp stamp_;                                    // guarded by mu_: of the file last read
  mutable std::chrono::steady_clock::time_point next_check_;   // guarded by mu_
};

}  // namespace zoomwarp::api
