#include "tiles/s3_credentials.h"

#include <curl/curl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <condition_variable>
#include <ctime>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "tiles/s3_config.h"
#include "tiles/s3_xml.h"

namespace zoomwarp::tiles {

namespace {

using SystemClock = std::chrono::system_clock;

// How long a request for credentials may take (STS, the container endpoint).
constexpr long kFetchTimeoutMs = 5000;

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::string trimmed(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n"), e = s.find_last_not_of(" \t\r\n");
  return b == std::string_view::npos ? std::string() : std::string(s.substr(b, e - b + 1));
}

std::size_t append_body(char* data, std::size_t size, std::size_t n, void* out) {
  auto* body = static_cast<std::string*>(out);
  if (body->size() + size * n > (1u << 20)) return 0;  // a credentials answer is small
  body->append(data, size * n);
  return size * n;
}

// One HTTP exchange with a credentials endpoint: the status and the body. `form`: POSTed as
// application/x-www-form-urlencoded (STS); else a GET.
std::pair<long, std::string> http_exchange(const std::string& url, const std::string& authorization,
                                           const std::string* form) {
  static const CURLcode init = curl_global_init(CURL_GLOBAL_DEFAULT);
  if (init != CURLE_OK) throw std::runtime_error("libcurl cannot start");
  const std::unique_ptr<CURL, decltype(&curl_easy_cleanup)> h(curl_easy_init(), &curl_easy_cleanup);
  if (!h) throw std::runtime_error("libcurl cannot start");
  std::string body;
  curl_slist* headers = nullptr;
  if (!authorization.empty()) headers = curl_slist_append(headers, ("Authorization: " + authorization).c_str());
  if (form) headers = curl_slist_append(headers, "Content-Type: application/x-www-form-urlencoded");
  headers = curl_slist_append(headers, "Accept: application/json, text/xml");
  const std::unique_ptr<curl_slist, decltype(&curl_slist_free_all)> header_list(headers, &curl_slist_free_all);
  curl_easy_setopt(h.get(), CURLOPT_URL, url.c_str());
  curl_easy_setopt(h.get(), CURLOPT_PROTOCOLS_STR, "http,https");
  curl_easy_setopt(h.get(), CURLOPT_NOSIGNAL, 1L);
  curl_easy_setopt(h.get(), CURLOPT_TIMEOUT_MS, kFetchTimeoutMs);
  curl_easy_setopt(h.get(), CURLOPT_HTTPHEADER, header_list.get());
  curl_easy_setopt(h.get(), CURLOPT_USERAGENT, "zoomwarp-s3");
  curl_easy_setopt(h.get(), CURLOPT_WRITEFUNCTION, &append_body);
  curl_easy_setopt(h.get(), CURLOPT_WRITEDATA, &body);
  if (form) {
    curl_easy_setopt(h.get(), CURLOPT_POSTFIELDS, form->c_str());
    curl_easy_setopt(h.get(), CURLOPT_POSTFIELDSIZE_LARGE, curl_off_t(form->size()));
  }
  const CURLcode code = curl_easy_perform(h.get());
  if (code != CURLE_OK) throw std::runtime_error(std::string(curl_easy_strerror(code)) + " at " + url);
  long status = 0;
  curl_easy_getinfo(h.get(), CURLINFO_RESPONSE_CODE, &status);
  return {status, std::move(body)};
}

std::string form_encoded(std::string_view s) { return s3_uri_encode(s, false); }

// Renewed before expiry (sources 3 and 4): one request renews while the others sign with what is
// still valid; a request finding them expired waits for the renewal.
class RenewedCredentials : public S3CredentialSource {
 public:
  S3Credentials current() override {
    std::unique_lock lock(mu_);
    for (;;) {
      const auto now = SystemClock::now();
      const bool valid = have_ && (!held_.expiration || now < *held_.expiration);
      if (valid && !stale_ && now < renew_at_) return held_;
      if (renewing_) {
        if (valid) return held_;
        renewed_.wait(lock);
        continue;
      }
      renewing_ = true;
      lock.unlock();
      std::optional<S3Credentials> fresh;
      std::string failure;
      try {
        fresh = fetch();
      } catch (const std::exception& e) {
        failure = e.what();
      }
      lock.lock();
      renewing_ = false;
      renewed_.notify_all();
      const auto after = SystemClock::now();
      if (fresh) {
        held_ = std::move(*fresh);
        have_ = true, stale_ = false;
        // Half the lifetime, or all but 5 minutes of it, whichever comes first.
        renew_at_ = held_.expiration
                        ? *held_.expiration - std::min<SystemClock::duration>(std::chrono::minutes(5),
                                                                             (*held_.expiration - after) / 2)
                        : SystemClock::time_point::max();
        return held_;
      }
      if (have_ && (!held_.expiration || after < *held_.expiration)) {
        renew_at_ = after + std::chrono::seconds(1);  // still valid: try again in a second
        return held_;
      }
      throw S3CredentialsError(describe() + ": " + failure);
    }
  }

  void refused(const S3Credentials& used) override {
    std::lock_guard lock(mu_);
    if (have_ && used.session_token == held_.session_token && used.access_key_id == held_.access_key_id) stale_ = true;
  }

 protected:
  // New credentials from the source; throws what went wrong.
  virtual S3Credentials fetch() = 0;

 private:
  std::mutex mu_;
  std::condition_variable renewed_;
  S3Credentials held_;
  bool have_ = false, stale_ = false, renewing_ = false;
  SystemClock::time_point renew_at_{};
};

class FixedCredentials final : public S3CredentialSource {
 public:
  explicit FixedCredentials(S3Credentials c) : c_(std::move(c)) {}
  S3Credentials current() override { return c_; }
  void refused(const S3Credentials&) override {}
  std::string describe() const override { return "the environment's keys"; }

 private:
  const S3Credentials c_;
};

class WebIdentityCredentials final : public RenewedCredentials {
 public:
  WebIdentityCredentials(std::string token_file, std::string role_arn, std::string session_name, std::string sts)
      : token_file_(std::move(token_file)), role_arn_(std::move(role_arn)), session_(std::move(session_name)),
        sts_(std::move(sts)) {}
  std::string describe() const override { return "web identity for " + role_arn_ + " (STS at " + sts_ + ")"; }

 protected:
  S3Credentials fetch() override {
    const std::string token = trimmed(read_file(token_file_));
    if (token.empty()) throw std::runtime_error(token_file_ + " is empty");
    const std::string form = "Action=AssumeRoleWithWebIdentity&DurationSeconds=3600&RoleArn=" + form_encoded(role_arn_) +
                             "&RoleSessionName=" + form_encoded(session_) + "&Version=2011-06-15&WebIdentityToken=" +
                             form_encoded(token);
    const auto [status, body] = http_exchange(sts_ + "/", "", &form);
    if (status != 200) {
      std::string code, message;
      parse_xml(body, [&](const std::string& path, std::string& text) {
        if (path == "ErrorResponse/Error/Code") code = text;
        else if (path == "ErrorResponse/Error/Message") message = text;
      });
      throw std::runtime_error("STS answered " + std::to_string(status) + (code.empty() ? "" : " " + code) +
                               (message.empty() ? "" : ": " + message));
    }
    auto c = parse_sts_credentials(body);
    if (!c) throw std::runtime_error("STS's answer holds no credentials");
    return std::move(*c);
  }

 private:
  const std::string token_file_, role_arn_, session_, sts_;
};

class ContainerCredentials final : public RenewedCredentials {
 public:
  ContainerCredentials(std::string url, std::string token_file, std::string token)
      : url_(std::move(url)), token_file_(std::move(token_file)), token_(std::move(token)) {}
  std::string describe() const override { return "the container credentials endpoint " + url_; }

 protected:
  S3Credentials fetch() override {
    const std::string authorization = token_file_.empty() ? token_ : trimmed(read_file(token_file_));
    const auto [status, body] = http_exchange(url_, authorization, nullptr);
    if (status != 200) throw std::runtime_error("it answered " + std::to_string(status));
    auto c = parse_container_credentials(body);
    if (!c) throw std::runtime_error("its answer holds no credentials");
    return std::move(*c);
  }

 private:
  const std::string url_, token_file_, token_;
};

// Source 2: the file's profile, read again when the file changes.
class FileCredentials final : public S3CredentialSource {
 public:
  FileCredentials(std::string path, std::string profile) : path_(std::move(path)), profile_(std::move(profile)) {}

  S3Credentials current() override {
    std::lock_guard lock(mu_);
    const auto now = std::chrono::steady_clock::now();
    if (have_ && !stale_ && now < next_look_) return held_;
    next_look_ = now + std::chrono::seconds(1);
    struct stat st {};
    if (::stat(path_.c_str(), &st) != 0) {
      if (have_) return held_;
      throw S3CredentialsError(describe() + ": the file is gone");
    }
    const std::pair<std::int64_t, std::int64_t> seen{std::int64_t(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec,
                                                     std::int64_t(st.st_size)};
    if (have_ && !stale_ && seen == stamp_) return held_;
    std::optional<S3Credentials> c;
    try {
      c = parse_shared_credentials(read_file(path_), profile_);
    } catch (const std::exception&) {
    }
    if (!c) {
      if (have_) return held_;  // half-written: the last good reading stands, looked at again in a second
      throw S3CredentialsError(describe() + ": no aws_access_key_id and aws_secret_access_key in the profile");
    }
    held_ = std::move(*c), have_ = true, stale_ = false, stamp_ = seen;
    return held_;
  }

  void refused(const S3Credentials&) override {
    std::lock_guard lock(mu_);
    stale_ = true;
  }

  std::string describe() const override { return "profile " + profile_ + " of " + path_; }

 private:
  const std::string path_, profile_;
  std::mutex mu_;
  S3Credentials held_;
  bool have_ = false, stale_ = false;
  std::pair<std::int64_t, std::int64_t> stamp_{};
  std::chrono::steady_clock::time_point next_look_{};
};

std::optional<std::string> http_url(const std::string& s) {
  if (s.rfind("http://", 0) != 0 && s.rfind("https://", 0) != 0) return std::nullopt;
  std::string u = s;
  while (u.size() > 8 && u.back() == '/') u.pop_back();
  return u;
}

}  // namespace

std::optional<SystemClock::time_point> parse_utc_time(std::string_view s) {
  std::tm tm{};
  int consumed = 0;
  const std::string text(s);
  if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%2d%n", &tm.tm_year, &tm.tm_mon, &tm.tm_mday, &tm.tm_hour, &tm.tm_min,
                  &tm.tm_sec, &consumed) != 6)
    return std::nullopt;
  std::string_view rest = s.substr(std::size_t(consumed));
  if (!rest.empty() && rest.front() == '.') {
    rest.remove_prefix(1);
    while (!rest.empty() && rest.front() >= '0' && rest.front() <= '9') rest.remove_prefix(1);
  }
  if (rest != "Z" && rest != "+00:00") return std::nullopt;
  tm.tm_year -= 1900, tm.tm_mon -= 1;
  const std::time_t t = ::timegm(&tm);
  if (t == std::time_t(-1)) return std::nullopt;
  return SystemClock::from_time_t(t);
}

std::optional<S3Credentials> parse_sts_credentials(std::string_view xml) {
  S3Credentials c;
  std::string expiration;
  const std::string base = "AssumeRoleWithWebIdentityResponse/AssumeRoleWithWebIdentityResult/Credentials/";
  const bool ok = parse_xml(xml, [&](const std::string& path, std::string& text) {
    if (path == base + "AccessKeyId") c.access_key_id = trimmed(text);
    else if (path == base + "SecretAccessKey") c.secret_access_key = trimmed(text);
    else if (path == base + "SessionToken") c.session_token = trimmed(text);
    else if (path == base + "Expiration") expiration = trimmed(text);
  });
  c.expiration = parse_utc_time(expiration);
  if (!ok || c.access_key_id.empty() || c.secret_access_key.empty() || !c.expiration) return std::nullopt;
  return c;
}

std::optional<S3Credentials> parse_container_credentials(std::string_view json) {
  const nlohmann::json j = nlohmann::json::parse(json, nullptr, false);
  if (!j.is_object()) return std::nullopt;
  auto text = [&](const char* name) { return j.contains(name) && j[name].is_string() ? j[name].get<std::string>() : ""; };
  S3Credentials c{text("AccessKeyId"), text("SecretAccessKey"), text("Token"), std::nullopt};
  if (const std::string e = text("Expiration"); !e.empty()) {
    c.expiration = parse_utc_time(e);
    if (!c.expiration) return std::nullopt;
  }
  if (c.access_key_id.empty() || c.secret_access_key.empty()) return std::nullopt;
  return c;
}

std::optional<S3Credentials> parse_shared_credentials(std::string_view ini, std::string_view profile) {
  S3Credentials c;
  bool in_profile = false;
  std::istringstream lines{std::string(ini)};
  for (std::string line; std::getline(lines, line);) {
    const std::string t = trimmed(line);
    if (t.empty() || t[0] == '#' || t[0] == ';') continue;
    if (t.front() == '[') {
      in_profile = t.back() == ']' && trimmed(std::string_view(t).substr(1, t.size() - 2)) == profile;
      continue;
    }
    const std::size_t eq = t.find('=');
    if (!in_profile || eq == std::string::npos) continue;
    const std::string key = trimmed(std::string_view(t).substr(0, eq)), value = trimmed(std::string_view(t).substr(eq + 1));
    if (key == "aws_access_key_id") c.access_key_id = value;
    else if (key == "aws_secret_access_key") c.secret_access_key = value;
    else if (key == "aws_session_token") c.session_token = value;
  }
  if (c.access_key_id.empty() || c.secret_access_key.empty()) return std::nullopt;
  return c;
}

std::shared_ptr<S3CredentialSource> fixed_credentials(S3Credentials credentials) {
  return std::make_shared<FixedCredentials>(std::move(credentials));
}

std::shared_ptr<S3CredentialSource> credentials_from_environment(
    const std::function<std::optional<std::string>(const char* name)>& lookup, const std::string& region) {
  auto get = [&](const char* name) {
    const auto v = lookup(name);
    return v ? *v : std::string();
  };
  // 1. The environment's keys (S3Config::from_environment checks them).
  const std::string key = get("AWS_ACCESS_KEY_ID"), secret = get("AWS_SECRET_ACCESS_KEY");
  if (!key.empty() || !secret.empty()) {
    if (key.empty() || secret.empty())
      throw S3ConfigError(std::string(key.empty() ? "AWS_ACCESS_KEY_ID" : "AWS_SECRET_ACCESS_KEY") +
                          " is not set, but " + (key.empty() ? "AWS_SECRET_ACCESS_KEY" : "AWS_ACCESS_KEY_ID") + " is");
    return fixed_credentials({key, secret, get("AWS_SESSION_TOKEN"), std::nullopt});
  }
  // 2. A shared credentials file with the profile.
  std::string file = get("AWS_SHARED_CREDENTIALS_FILE");
  if (file.empty() && !get("HOME").empty()) file = get("HOME") + "/.aws/credentials";
  const std::string profile = get("AWS_PROFILE").empty() ? "default" : get("AWS_PROFILE");
  if (!file.empty() && ::access(file.c_str(), R_OK) == 0) {
    try {
      if (parse_shared_credentials(read_file(file), profile)) return std::make_shared<FileCredentials>(file, profile);
    } catch (const std::exception&) {
    }
  }
  // 3. Web identity.
  const std::string token_file = get("AWS_WEB_IDENTITY_TOKEN_FILE"), role = get("AWS_ROLE_ARN");
  if (!token_file.empty() && !role.empty()) {
    std::string sts = get("AWS_ENDPOINT_URL_STS");
    const char* sts_var = "AWS_ENDPOINT_URL_STS";
    if (sts.empty()) sts = get("AWS_ENDPOINT_URL"), sts_var = "AWS_ENDPOINT_URL";
    if (sts.empty()) sts = "https://sts." + region + ".amazonaws.com";
    const auto url = http_url(sts);
    if (!url) throw S3ConfigError(std::string(sts_var) + "='" + sts + "' is not an http(s) URL");
    const std::string session = get("AWS_ROLE_SESSION_NAME").empty() ? "zoomwarp-" + std::to_string(::getpid())
                                                                      : get("AWS_ROLE_SESSION_NAME");
    return std::make_shared<WebIdentityCredentials>(token_file, role, session, *url);
  }
  // 4. The container endpoint.
  std::string endpoint = get("AWS_CONTAINER_CREDENTIALS_FULL_URI");
  if (endpoint.empty() && !get("AWS_CONTAINER_CREDENTIALS_RELATIVE_URI").empty())
    endpoint = "http://169.254.170.2" + get("AWS_CONTAINER_CREDENTIALS_RELATIVE_URI");
  if (!endpoint.empty()) {
    if (!http_url(endpoint)) throw S3ConfigError("AWS_CONTAINER_CREDENTIALS_FULL_URI='" + endpoint + "' is not an http(s) URL");
    return std::make_shared<ContainerCredentials>(endpoint, get("AWS_CONTAINER_AUTHORIZATION_TOKEN_FILE"),
                                                  get("AWS_CONTAINER_AUTHORIZATION_TOKEN"));
  }
  throw S3ConfigError(
      "an s3:// store needs credentials: AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY (optionally AWS_SESSION_TOKEN), "
      "a shared credentials file (AWS_SHARED_CREDENTIALS_FILE or ~/.aws/credentials, profile AWS_PROFILE), "
      "AWS_WEB_IDENTITY_TOKEN_FILE with AWS_ROLE_ARN, or AWS_CONTAINER_CREDENTIALS_FULL_URI; none is set");
}

}  // namespace zoomwarp::tiles
