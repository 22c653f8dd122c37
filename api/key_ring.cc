#include "api/key_ring.h"

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>
#include <openssl/sha.h>
#include <sys/stat.h>

#include <cctype>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include "api/hex.h"

namespace zoomwarp::api {

namespace {

constexpr std::size_t kMinKeyChars = 16;
constexpr std::size_t kMaxKeyIdChars = 64;
constexpr std::string_view kDigestPrefix = "sha256:";
// Checking the file's stamp costs a stat(2); once a second is quick enough for a rotation.
constexpr auto kCheckInterval = std::chrono::seconds(1);

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

std::vector<std::string_view> fields_of(std::string_view line) {
  std::vector<std::string_view> fields;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_space(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !is_space(line[i])) ++i;
    if (i > start) fields.push_back(line.substr(start, i - start));
  }
  return fields;
}

std::optional<KeyDigest> parse_digest(std::string_view hex) {
  KeyDigest d{};
  const auto bytes = hex_decode(hex);
  if (!bytes || bytes->size() != d.size()) return std::nullopt;
  std::copy(bytes->begin(), bytes->end(), d.begin());
  return d;
}

// The key field of a line: the digest it stands for. Messages never quote the field.
KeyDigest key_field_digest(std::string_view field, const std::string& where) {
  if (field.substr(0, kDigestPrefix.size()) == kDigestPrefix) {
    if (auto d = parse_digest(field.substr(kDigestPrefix.size()))) return *d;
    throw KeyFileError(where + ": a sha256: key must be followed by 64 hex digits");
  }
  if (field.size() < kMinKeyChars)
    throw KeyFileError(where + ": the key is shorter than " + std::to_string(kMinKeyChars) + " characters");
  return key_digest(field);
}

KeyEntry parse_line(std::string_view line, const std::string& where) {
  const auto fields = fields_of(line);
  if (fields.size() != 3) throw KeyFileError(where + ": expected KEY_ID ROLE KEY");
  KeyEntry e;
  if (!is_valid_key_id(fields[0]))
    throw KeyFileError(where + ": a key id is 1-64 characters from A-Z a-z 0-9 . _ -");
  e.key_id = std::string(fields[0]);
  try {
    e.role = parse_role(fields[1]);
  } catch (const std::invalid_argument&) {
    throw KeyFileError(where + ": the role must be reader, curator or admin");
  }
  e.digest = key_field_digest(fields[2], where);
  return e;
}

// "Bearer KEY" → KEY (the scheme is case-insensitive, RFC 9110 §11.1); empty if it is not one.
std::string_view bearer_token(std::string_view authorization) {
  constexpr std::string_view kScheme = "bearer";
  if (authorization.size() <= kScheme.size() || !is_space(authorization[kScheme.size()])) return {};
  for (std::size_t i = 0; i < kScheme.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(authorization[i])) != kScheme[i]) return {};
  std::string_view token = authorization.substr(kScheme.size());
  while (!token.empty() && is_space(token.front())) token.remove_prefix(1);
  while (!token.empty() && is_space(token.back())) token.remove_suffix(1);
  return token;
}

std::string read_whole(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read the key file " + path);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

bool is_valid_key_id(std::string_view id) {
  if (id.empty() || id.size() > kMaxKeyIdChars) return false;
  for (char c : id)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
  return true;
}

std::string_view role_name(Role role) {
  switch (role) {
    case Role::kReader: return "reader";
    case Role::kCurator: return "curator";
    case Role::kAdmin: return "admin";
  }
  return "reader";
}

Role parse_role(std::string_view name) {
  if (name == "reader") return Role::kReader;
  if (name == "curator") return Role::kCurator;
  if (name == "admin") return Role::kAdmin;
  throw std::invalid_argument("unknown role '" + std::string(name) + "' (reader, curator or admin)");
}

KeyDigest key_digest(std::string_view key) {
  KeyDigest d{};
  SHA256(reinterpret_cast<const unsigned char*>(key.data()), key.size(), d.data());
  return d;
}

std::string digest_hex(const KeyDigest& digest) { return hex_encode(digest.data(), digest.size()); }

std::string random_key() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof bytes) != 1) throw std::runtime_error("the random number generator failed");
  unsigned char b64[48];
  const int n = EVP_EncodeBlock(b64, bytes, sizeof bytes);  // standard base64 with padding
  std::string key(reinterpret_cast<const char*>(b64), std::size_t(n));
  while (!key.empty() && key.back() == '=') key.pop_back();
  for (char& c : key) c = c == '+' ? '-' : c == '/' ? '_' : c;  // url-safe: pastes into headers and shells
  return key;
}

std::vector<KeyEntry> parse_key_file(std::string_view text) {
  std::vector<KeyEntry> keys;
  std::set<std::string> ids;
  std::set<KeyDigest> digests;  // one key under two ids would make its holder's id a guess
  int line_no = 0;
  while (!text.empty()) {
    const std::size_t end = std::min(text.find('\n'), text.size());
    const std::string_view line = text.substr(0, end);
    text.remove_prefix(std::min(end + 1, text.size()));
    ++line_no;
    const auto fields = fields_of(line);
    if (fields.empty() || fields[0].front() == '#') continue;
    const std::string where = "line " + std::to_string(line_no);
    KeyEntry e = parse_line(line, where);
    if (!ids.insert(e.key_id).second) throw KeyFileError(where + ": key id '" + e.key_id + "' is given twice");
    if (!digests.insert(e.digest).second) throw KeyFileError(where + ": the same key is already given to another id");
    keys.push_back(std::move(e));
  }
  if (keys.empty()) throw KeyFileError("the key file holds no keys");
  return keys;
}

KeyRing::KeyRing(std::string path, Log log) : path_(std::move(path)), log_(std::move(log)) {
  stamp_ = stamp_of(path_);
  try {
    keys_ = std::make_shared<const std::vector<KeyEntry>>(parse_key_file(read_whole(path_)));
  } catch (const KeyFileError& e) {
    throw KeyFileError("the key file " + path_ + ", " + e.what());
  }
  next_check_ = std::chrono::steady_clock::now() + kCheckInterval;
}

KeyRing::FileStamp KeyRing::stamp_of(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return {};
  return {std::int64_t(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec, std::uintmax_t(st.st_size),
          std::uint64_t(st.st_ino)};
}

bool KeyRing::reload() {
  std::lock_guard lock(mu_);
  return load();
}

bool KeyRing::load() const {
  // The stamp is taken first: a write after it is seen by the next check.
  stamp_ = stamp_of(path_);
  try {
    auto keys = std::make_shared<const std::vector<KeyEntry>>(parse_key_file(read_whole(path_)));
    const std::size_t n = keys->size();
    keys_ = std::move(keys);
    if (log_) log_("info", "keys reloaded: " + std::to_string(n) + " in force");
    return true;
  } catch (const std::exception& e) {
    if (log_) log_("error", std::string("the key file ") + path_ + " was not reloaded, the old keys stay: " + e.what());
    return false;
  }
}

void KeyRing::reload_if_changed() const {
  std::lock_guard lock(mu_);
  const auto now = std::chrono::steady_clock::now();
  if (now < next_check_) return;
  next_check_ = now + kCheckInterval;
  if (!(stamp_of(path_) == stamp_)) load();
}

std::shared_ptr<const std::vector<KeyEntry>> KeyRing::current_keys() const {
  reload_if_changed();
  std::lock_guard lock(mu_);
  return keys_;
}

Authenticator::Result KeyRing::authenticate(std::string_view authorization) const {
  Result result;
  if (authorization.empty()) return result;
  result.outcome = Outcome::kInvalid;
  const std::string_view token = bearer_token(authorization);
  if (token.empty()) return result;
  const KeyDigest presented = key_digest(token);
  // Every stored digest is compared, whatever matched before: the time taken says nothing about
  // which key, or how much of one, was right.
  const KeyEntry* match = nullptr;
  const auto keys = current_keys();
  for (const KeyEntry& e : *keys)
    if (CRYPTO_memcmp(presented.data(), e.digest.data(), presented.size()) == 0) match = &e;
  if (match) result = {Outcome::kValid, {match->key_id, match->role}};
  return result;
}

bool KeyRing::has_keys() const { return !current_keys()->empty(); }

std::size_t KeyRing::size() const { return current_keys()->size(); }

}  // namespace zoomwarp::api
