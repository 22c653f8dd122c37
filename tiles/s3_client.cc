#include "tiles/s3_client.h"

#include <curl/curl.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstring>
#include <functional>
#include <mutex>
#include <random>
#include <system_error>
#include <thread>
#include <utility>

#include "tiles/s3_xml.h"
#include "tiles/source_digest.h"

namespace zoomwarp::tiles {

namespace {

using Clock = std::chrono::steady_clock;

// SHA-256 of no bytes: the payload hash of GET, HEAD and DELETE.
constexpr const char* kEmptySha256 = "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855";
// What an error document is kept to: enough for any S3 <Error>, bounded against a proxy's page.
constexpr std::size_t kMaxErrorBody = 64 * 1024;
// Less time than this left after a failure: no further attempt.
constexpr std::chrono::milliseconds kMinAttemptTime{5};

bool is_sha256_hex(std::string_view s) {
  return s.size() == 64 && std::all_of(s.begin(), s.end(), [](char c) {
           return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
         });
}

std::string unquoted(std::string_view etag) {
  if (etag.size() >= 2 && etag.front() == '"' && etag.back() == '"') etag = etag.substr(1, etag.size() - 2);
  return std::string(etag);
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

// What encoding-type=url listings hold: %XX escapes, and '+' for a space (AWS writes spaces so;
// Swift escapes '+' itself as %2B, so a '+' read here is never a plus).
std::string url_decoded(std::string_view s) {
  std::string out;
  out.reserve(s.size());
  for (std::size_t i = 0; i < s.size(); ++i) {
    if (s[i] == '+') {
      out += ' ';
    } else if (s[i] == '%' && i + 2 < s.size() && hex_value(s[i + 1]) >= 0 && hex_value(s[i + 2]) >= 0) {
      out += char(hex_value(s[i + 1]) * 16 + hex_value(s[i + 2]));
      i += 2;
    } else {
      out += s[i];
    }
  }
  return out;
}

struct ErrorDocument {
  std::string code, message, request_id;
};

ErrorDocument parse_error_document(std::string_view body) {
  ErrorDocument e;
  if (body.find("<Error") == std::string_view::npos) return e;
  parse_xml(body, [&](const std::string& path, std::string& text) {
    if (path == "Error/Code") e.code = std::move(text);
    else if (path == "Error/Message") e.message = std::move(text);
    else if (path == "Error/RequestId") e.request_id = std::move(text);
  });
  return e;
}

bool retryable_status(long status) {
  return status == 408 || status == 429 || status == 500 || status == 502 || status == 503 || status == 504;
}

// Transport failures worth another attempt: the store may be back, or the next connection fine.
bool retryable_transport(CURLcode c) {
  switch (c) {
    case CURLE_COULDNT_RESOLVE_HOST:
    case CURLE_COULDNT_CONNECT:
    case CURLE_OPERATION_TIMEDOUT:
    case CURLE_SEND_ERROR:
    case CURLE_RECV_ERROR:
    case CURLE_GOT_NOTHING:
    case CURLE_PARTIAL_FILE:
    case CURLE_SSL_CONNECT_ERROR:
    case CURLE_HTTP2:
    case CURLE_HTTP2_STREAM:
    case CURLE_WEIRD_SERVER_REPLY:
      return true;
    default:
      return false;
  }
}

void ensure_curl_global() {
  static const CURLcode init = curl_global_init(CURL_GLOBAL_DEFAULT);
  if (init != CURLE_OK) throw std::runtime_error(std::string("libcurl initialisation failed: ") + curl_easy_strerror(init));
}

// DNS answers and TLS sessions shared by every handle of one client, each kind under its own
// mutex as CURLSHOPT_LOCKFUNC asks (libcurl takes one kind at a time).
class CurlShare {
 public:
  CurlShare() : share_(curl_share_init()) {
    if (share_ == nullptr) throw std::bad_alloc();
    curl_share_setopt(share_, CURLSHOPT_USERDATA, this);
    curl_share_setopt(share_, CURLSHOPT_LOCKFUNC, &CurlShare::lock);
    curl_share_setopt(share_, CURLSHOPT_UNLOCKFUNC, &CurlShare::unlock);
    curl_share_setopt(share_, CURLSHOPT_SHARE, CURL_LOCK_DATA_DNS);
    curl_share_setopt(share_, CURLSHOPT_SHARE, CURL_LOCK_DATA_SSL_SESSION);
  }
  ~CurlShare() { curl_share_cleanup(share_); }
  CURLSH* get() const { return share_; }

 private:
  static void lock(CURL*, curl_lock_data data, curl_lock_access, void* self) {
    static_cast<CurlShare*>(self)->mutexes_[std::size_t(data)].lock();
  }
  static void unlock(CURL*, curl_lock_data data, void* self) {
    static_cast<CurlShare*>(self)->mutexes_[std::size_t(data)].unlock();
  }
  CURLSH* share_;
  std::array<std::mutex, CURL_LOCK_DATA_LAST> mutexes_;
};

// Easy handles, each with its own connection cache, lent to one request at a time.
class HandlePool {
 public:
  HandlePool(CURLSH* share, std::size_t max_idle) : share_(share), max_idle_(max_idle) {}
  ~HandlePool() {
    for (CURL* h : idle_) curl_easy_cleanup(h);
  }

  CURL* acquire() {
    {
      std::lock_guard lock(mu_);
      if (!idle_.empty()) {
        CURL* h = idle_.back();
        idle_.pop_back();
        return h;
      }
    }
    CURL* h = curl_easy_init();
    if (h == nullptr) throw std::bad_alloc();
    // Kept through curl_easy_reset (which keeps "live connections… the shares").
    curl_easy_setopt(h, CURLOPT_SHARE, share_);
    return h;
  }

  void release(CURL* h) {
    {
      std::lock_guard lock(mu_);
      if (idle_.size() < max_idle_) {
        idle_.push_back(h);
        return;
      }
    }
    curl_easy_cleanup(h);
  }

 private:
  CURLSH* share_;
  std::size_t max_idle_;
  std::mutex mu_;
  std::vector<CURL*> idle_;  // the back was returned last: its connection is the warmest
};

// A handle borrowed for one attempt. It goes back reset: no option points into the frame of the
// attempt that used it (error buffer, header list, callbacks' data) once that frame is gone, and
// curl_easy_reset keeps the handle's live connections and its share.
struct Lease {
  HandlePool& pool;
  CURL* handle;
  explicit Lease(HandlePool& p) : pool(p), handle(p.acquire()) {}
  ~Lease() {
    curl_easy_reset(handle);
    pool.release(handle);
  }
  Lease(const Lease&) = delete;
  Lease& operator=(const Lease&) = delete;
};

struct HeaderList {
  curl_slist* list = nullptr;
  ~HeaderList() { curl_slist_free_all(list); }
  void add(const std::string& line) {
    curl_slist* l = curl_slist_append(list, line.c_str());
    if (l == nullptr) throw std::bad_alloc();
    list = l;
  }
};

// A request body, from memory or a file, read by libcurl through read_body and rewound by
// seek_body.
struct Body {
  std::string_view memory;
  int fd = -1;
  std::uint64_t size = 0;
  std::uint64_t offset = 0;
  int read_errno = 0;
  bool shrank = false;
};

std::size_t read_body(char* buffer, std::size_t size, std::size_t count, void* p) {
  auto* b = static_cast<Body*>(p);
  const std::size_t want = std::size_t(std::min<std::uint64_t>(size * count, b->size - b->offset));
  if (want == 0) return 0;
  if (b->fd < 0) {
    std::memcpy(buffer, b->memory.data() + b->offset, want);
    b->offset += want;
    return want;
  }
  for (;;) {
    const ssize_t n = ::pread(b->fd, buffer, want, off_t(b->offset));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) {
      b->read_errno = errno;
      return CURL_READFUNC_ABORT;
    }
    if (n == 0) {  // shorter than when it was measured
      b->shrank = true;
      return CURL_READFUNC_ABORT;
    }
    b->offset += std::uint64_t(n);
    return std::size_t(n);
  }
}

int seek_body(void* p, curl_off_t offset, int origin) {
  auto* b = static_cast<Body*>(p);
  if (origin != SEEK_SET || offset < 0 || std::uint64_t(offset) > b->size) return CURL_SEEKFUNC_CANTSEEK;
  b->offset = std::uint64_t(offset);
  return CURL_SEEKFUNC_OK;
}

struct Response {
  long status = 0;
  std::string body;
  std::string etag, content_type, content_range, request_id;
  std::optional<std::uint64_t> content_length;
  // Retry-After of a retryable answer, delta-seconds (RFC 9110 §10.2.3; the HTTP-date form is
  // not sent by S3 stores and is taken as absent).
  std::optional<std::uint64_t> retry_after_s;
  bool range_ignored = false;  // a ranged GET answered 200: cut at once
  bool body_too_long = false;  // more bytes than asked for
  int attempts = 0;            // requests made to get it
};

// Where a response body goes: `max_body` bytes at most of a 2xx body (more is cut, and the
// transfer fails), kMaxErrorBody of another (the rest dropped, the transfer goes on so that the
// connection stays usable).
struct Sink {
  Response* response;
  CURL* handle;
  std::size_t max_body;
  bool ranged;
  bool started = false;
};

std::size_t write_body(char* data, std::size_t size, std::size_t count, void* p) {
  auto* s = static_cast<Sink*>(p);
  const std::size_t n = size * count;
  long status = 0;
  curl_easy_getinfo(s->handle, CURLINFO_RESPONSE_CODE, &status);
  const bool success = status >= 200 && status < 300;
  if (!s->started) {
    s->started = true;
    if (s->ranged && status == 200) {
      s->response->range_ignored = true;
      return 0;
    }
    curl_off_t length = -1;
    curl_easy_getinfo(s->handle, CURLINFO_CONTENT_LENGTH_DOWNLOAD_T, &length);
    if (success && length > 0 && std::uint64_t(length) <= s->max_body) s->response->body.reserve(std::size_t(length));
  }
  std::string& body = s->response->body;
  if (!success) {
    if (body.size() < kMaxErrorBody) body.append(data, std::min(n, kMaxErrorBody - body.size()));
    return n;
  }
  if (n > s->max_body - body.size()) {
    s->response->body_too_long = true;
    return 0;
  }
  body.append(data, n);
  return n;
}

std::string header_value(CURL* h, const char* name) {
  curl_header* header = nullptr;
  if (curl_easy_header(h, name, 0, CURLH_HEADER, -1, &header) != CURLHE_OK || header == nullptr) return {};
  return header->value;
}

std::optional<std::uint64_t> parse_u64(std::string_view s) {
  if (s.empty() || s.size() > 20) return std::nullopt;
  std::uint64_t v = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return std::nullopt;
    const std::uint64_t next = v * 10 + std::uint64_t(c - '0');
    if (next / 10 != v) return std::nullopt;
    v = next;
  }
  return v;
}

struct OpenFile {
  int fd = -1;
  ~OpenFile() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

const char* s3_operation_name(S3Operation op) {
  switch (op) {
    case S3Operation::kGet: return "get";
    case S3Operation::kGetRange: return "get_range";
    case S3Operation::kHead: return "head";
    case S3Operation::kPut: return "put";
    case S3Operation::kPutFile: return "put_file";
    case S3Operation::kRemove: return "remove";
    case S3Operation::kList: return "list";
    case S3Operation::kCreateBucket: return "create_bucket";
    case S3Operation::kCopy: return "copy";
  }
  return "?";
}

namespace {

bool credentials_code(std::string_view code) {
  return code == "InvalidAccessKeyId" || code == "SignatureDoesNotMatch" || code == "ExpiredToken" ||
         code == "InvalidToken" || code == "TokenRefreshRequired" || code == "InvalidSecurity";
}

std::string describe_error(const S3Error::Details& d) {
  std::string what = std::string("S3 ") + s3_operation_name(d.operation) + " s3://" + d.bucket;
  if (!d.key.empty()) what += "/" + d.key;
  what += ": ";
  if (d.status != 0) {
    what += "HTTP " + std::to_string(d.status);
    if (!d.code.empty()) what += " " + d.code;
    if (!d.message.empty()) what += ": " + d.message;
  } else {
    what += d.message;
  }
  if (d.status == 403) {
    if (credentials_code(d.code))
      what += " -- the store refused the credentials: check AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY "
              "(and AWS_SESSION_TOKEN, if set)";
    else if (d.code == "AccessDenied")
      what += " -- the credentials were accepted but may not do this here (bucket or IAM policy)";
    else if (d.code.empty())
      what += " -- the credentials were refused or lack the permission (a HEAD answer has no body to say which)";
  }
  if (d.code == "AuthorizationHeaderMalformed" || d.code == "PermanentRedirect" ||
      d.code == "IllegalLocationConstraintException")
    what += " -- check AWS_REGION";
  if (d.unavailable) what += d.timed_out ? " (store timed out)" : " (store unavailable)";
  if (d.attempts > 1) what += ", after " + std::to_string(d.attempts) + " attempts";
  if (!d.request_id.empty()) what += " [request " + d.request_id + "]";
  return what;
}

// A bucket and key that make a well-formed URL of one object (what parse_s3_location accepts,
// and S3's 1024-byte limit on keys); std::invalid_argument otherwise: a caller's bug, not the
// store's answer.
void check_names(const char* operation, std::string_view bucket, std::string_view key, bool key_needed = true) {
  if (!valid_bucket_name(bucket))
    throw std::invalid_argument(std::string("S3Client::") + operation + ": '" + std::string(bucket) +
                                "' is not a valid bucket name");
  if ((key_needed && key.empty()) || key.size() > 1024)
    throw std::invalid_argument(std::string("S3Client::") + operation + ": a key must be 1-1024 bytes");
}

}  // namespace

S3Error::S3Error(Details d) : std::runtime_error(describe_error(d)), d_(std::move(d)) {}

bool S3Error::credentials_refused() const { return d_.status == 403 && credentials_code(d_.code); }

struct S3Client::Impl {
  S3Config config;
  S3ClientOptions options;
  std::string sigv4;  // "aws:amz:REGION:s3"
  CurlShare share;    // before the pool: handles go first, then the share they use
  HandlePool pool;
  std::array<std::atomic<std::uint64_t>, kS3OperationCount> requests{};
  std::array<std::atomic<std::uint64_t>, kS3OperationCount> failures{};
  std::atomic<std::uint64_t> retries{0}, bytes_sent{0}, bytes_received{0};

  Impl(S3Config c, S3ClientOptions o)
      : config(std::move(c)),
        options(o),
        sigv4("aws:amz:" + config.region() + ":s3"),
        pool(share.get(), o.max_idle_handles) {
    options.max_attempts = std::max(1, options.max_attempts);
  }

  struct Request {
    Request(S3Operation o, const char* m, std::string_view b, std::string_view k, std::string u)
        : op(o), method(m), bucket(b), key(k), url(std::move(u)) {}
    S3Operation op;
    const char* method;  // "GET", "HEAD", "PUT", "DELETE"
    std::string_view bucket, key;
    std::string url;
    std::string payload_sha256 = kEmptySha256;
    std::vector<std::string> headers;  // besides x-amz-content-sha256 and x-amz-security-token
    Body* body = nullptr;              // PUT
    std::size_t max_body = SIZE_MAX;
    bool ranged = false;
  };

  S3Error::Details details(const Request& r) const {
    S3Error::Details d;
    d.operation = r.op;
    d.bucket = std::string(r.bucket);
    d.key = std::string(r.key);
    return d;
  }

  // The failure of an operation: counted, then thrown.
  [[noreturn]] void fail(S3Error::Details d) {
    failures[std::size_t(d.operation)].fetch_add(1, std::memory_order_relaxed);
    throw S3Error(std::move(d));
  }

  // An answer that is not what the operation expects, as an S3Error.
  [[noreturn]] void fail_answer(const Request& r, const Response& resp) {
    S3Error::Details d = details(r);
    d.status = int(resp.status);
    const ErrorDocument doc = parse_error_document(resp.body);
    d.code = doc.code;
    d.message = doc.message;
    d.request_id = doc.request_id.empty() ? resp.request_id : doc.request_id;
    d.attempts = resp.attempts;
    fail(std::move(d));
  }

  // One attempt on a borrowed handle. Returns libcurl's code; fills `resp` and `errbuf`.
  CURLcode attempt_once(const Request& r, const S3Credentials& creds, Response& resp, char* errbuf,
                        Clock::duration left) {
    HeaderList headers;  // destroyed after the lease has reset the handle that points to it
    headers.add("x-amz-content-sha256: " + r.payload_sha256);
    if (!creds.session_token.empty()) headers.add("x-amz-security-token: " + creds.session_token);
    for (const auto& line : r.headers) headers.add(line);

    const long left_ms = std::max<long>(1, long(std::chrono::duration_cast<std::chrono::milliseconds>(left).count()));
    Lease lease(pool);
    CURL* h = lease.handle;
    errbuf[0] = '\0';
    curl_easy_setopt(h, CURLOPT_ERRORBUFFER, errbuf);
    curl_easy_setopt(h, CURLOPT_NOSIGNAL, 1L);
    curl_easy_setopt(h, CURLOPT_URL, r.url.c_str());
    curl_easy_setopt(h, CURLOPT_PROTOCOLS_STR, "http,https");
    // Keys are names, not paths: "a/../b" is an object of its own, and its path must reach the
    // store (and be signed) as written.
    curl_easy_setopt(h, CURLOPT_PATH_AS_IS, 1L);
    curl_easy_setopt(h, CURLOPT_HTTP_VERSION, long(CURL_HTTP_VERSION_1_1));
    curl_easy_setopt(h, CURLOPT_USERAGENT, "zoomwarp-s3");
    curl_easy_setopt(h, CURLOPT_AWS_SIGV4, sigv4.c_str());
    curl_easy_setopt(h, CURLOPT_USERNAME, creds.access_key_id.c_str());
    curl_easy_setopt(h, CURLOPT_PASSWORD, creds.secret_access_key.c_str());
    curl_easy_setopt(h, CURLOPT_HTTPHEADER, headers.list);
    curl_easy_setopt(h, CURLOPT_TIMEOUT_MS, left_ms);
    curl_easy_setopt(h, CURLOPT_CONNECTTIMEOUT_MS,
                     std::min<long>(left_ms, long(options.connect_timeout.count())));
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_LIMIT, options.low_speed_bytes_per_second);
    curl_easy_setopt(h, CURLOPT_LOW_SPEED_TIME, long(options.low_speed_time.count()));
    curl_easy_setopt(h, CURLOPT_TCP_KEEPALIVE, 1L);
    Sink sink{&resp, h, r.max_body, r.ranged};
    curl_easy_setopt(h, CURLOPT_WRITEFUNCTION, &write_body);
    curl_easy_setopt(h, CURLOPT_WRITEDATA, &sink);
    if (std::strcmp(r.method, "HEAD") == 0) {
      curl_easy_setopt(h, CURLOPT_NOBODY, 1L);
    } else if (r.body != nullptr) {  // PUT, or POST with a body (multipart uploads)
      if (std::strcmp(r.method, "PUT") != 0) curl_easy_setopt(h, CURLOPT_CUSTOMREQUEST, r.method);
      r.body->offset = 0;
      curl_easy_setopt(h, CURLOPT_UPLOAD, 1L);
      curl_easy_setopt(h, CURLOPT_INFILESIZE_LARGE, curl_off_t(r.body->size));
      curl_easy_setopt(h, CURLOPT_READFUNCTION, &read_body);
      curl_easy_setopt(h, CURLOPT_READDATA, r.body);
      curl_easy_setopt(h, CURLOPT_SEEKFUNCTION, &seek_body);
      curl_easy_setopt(h, CURLOPT_SEEKDATA, r.body);
    } else if (std::strcmp(r.method, "GET") != 0) {
      curl_easy_setopt(h, CURLOPT_CUSTOMREQUEST, r.method);
    }

    requests[std::size_t(r.op)].fetch_add(1, std::memory_order_relaxed);
    const CURLcode code = curl_easy_perform(h);

    curl_off_t up = 0, down = 0;
    curl_easy_getinfo(h, CURLINFO_SIZE_UPLOAD_T, &up);
    curl_easy_getinfo(h, CURLINFO_SIZE_DOWNLOAD_T, &down);
    bytes_sent.fetch_add(std::uint64_t(std::max<curl_off_t>(0, up)), std::memory_order_relaxed);
    bytes_received.fetch_add(std::uint64_t(std::max<curl_off_t>(0, down)), std::memory_order_relaxed);
    curl_easy_getinfo(h, CURLINFO_RESPONSE_CODE, &resp.status);
    if (resp.status != 0) {
      resp.etag = unquoted(header_value(h, "ETag"));
      resp.content_type = header_value(h, "Content-Type");
      resp.content_range = header_value(h, "Content-Range");
      resp.request_id = header_value(h, "x-amz-request-id");
      resp.content_length = parse_u64(header_value(h, "Content-Length"));
      resp.retry_after_s = parse_u64(header_value(h, "Retry-After"));
    }
    // The handle goes back with its connection (libcurl closed it if it is not reusable).
    return code;
  }

  // Runs `r` until it gets an answer that is not worth retrying, and returns it (any status: the
  // operation decides what a 404 means). Throws S3Error when the store stays unreachable, slow or
  // failing until the attempts or the deadline run out, or for a transport failure no retry
  // mends; std::system_error when the body's file cannot be read.
  Response perform(const Request& r, S3Deadline deadline) {
    S3Error::Details last = details(r);
    bool refused_once = false;
    for (int attempt = 1;; ++attempt) {
      const auto now = Clock::now();
      // A retry with next to no time left would only time out (libcurl's timeout is whole
      // milliseconds, so an attempt that ran to the deadline may end a fraction of one before it).
      if (now >= deadline || (attempt > 1 && deadline - now < kMinAttemptTime)) {
        last.attempts = attempt - 1;
        last.unavailable = true;
        if (attempt == 1) {
          last.timed_out = true;
          last.message = "the deadline had passed before the request";
        }
        fail(std::move(last));
      }
      if (attempt > 1) retries.fetch_add(1, std::memory_order_relaxed);
      // Asked before every attempt: credentials that expire are renewed (s3_credentials.h).
      S3Credentials creds;
      try {
        creds = config.credentials();
      } catch (const S3CredentialsError& e) {
        last.attempts = attempt - 1;
        last.code = "CredentialsUnavailable";
        last.message = e.what();
        last.unavailable = true;
        fail(std::move(last));
      }
      Response resp;
      char errbuf[CURL_ERROR_SIZE];
      const CURLcode code = attempt_once(r, creds, resp, errbuf, deadline - now);
      resp.attempts = attempt;
      if (r.body != nullptr && r.body->read_errno != 0) {
        failures[std::size_t(r.op)].fetch_add(1, std::memory_order_relaxed);
        throw std::system_error(r.body->read_errno, std::generic_category(),
                                "S3 put_file s3://" + std::string(r.bucket) + "/" + std::string(r.key) + ": reading the file");
      }
      // Credentials the store calls expired (a renewal came too late, or a rotated file): renewed
      // and tried again at once, once.
      if (code == CURLE_OK && (resp.status == 400 || resp.status == 403) && attempt < options.max_attempts &&
          !refused_once) {
        const std::string error_code = parse_error_document(resp.body).code;
        if (error_code == "ExpiredToken" || error_code == "TokenRefreshRequired" || error_code == "InvalidToken") {
          config.credential_source().refused(creds);
          refused_once = true;
          continue;
        }
      }
      if (code == CURLE_OK && !retryable_status(resp.status)) return resp;
      if (resp.range_ignored || resp.body_too_long) return resp;  // the operation says what is wrong

      last = details(r);
      last.attempts = attempt;
      if (code == CURLE_OK) {  // a retryable status
        const ErrorDocument doc = parse_error_document(resp.body);
        last.status = int(resp.status);
        last.code = doc.code;
        last.message = doc.message;
        last.request_id = doc.request_id.empty() ? resp.request_id : doc.request_id;
        last.unavailable = true;
      } else {
        if (r.body != nullptr && r.body->shrank) {
          last.message = "the file became shorter while it was being sent";
          fail(std::move(last));
        }
        last.message = std::string(curl_easy_strerror(code));
        if (errbuf[0] != '\0') last.message += std::string(" (") + errbuf + ")";
        last.message += " at " + config.describe();
        if (!retryable_transport(code)) fail(std::move(last));
        last.unavailable = true;
        last.timed_out = code == CURLE_OPERATION_TIMEDOUT;
      }
      if (attempt >= options.max_attempts) fail(std::move(last));
      // Full jitter: a uniform sleep up to the exponential bound.
      const auto bound = std::min<std::chrono::milliseconds::rep>(
          options.max_backoff.count(),
          options.base_backoff.count() << std::min(attempt - 1, 20));
      thread_local std::minstd_rand rng{std::random_device{}()};
      auto sleep = std::chrono::milliseconds(
          std::uniform_int_distribution<std::chrono::milliseconds::rep>(0, std::max<long long>(0, bound))(rng));
      // The store's own Retry-After (SlowDown, 503) is honoured: never sooner than it asks; if
      // that is past the deadline, the failure is answered now rather than after waiting.
      if (code == CURLE_OK && resp.retry_after_s)
        sleep = std::max<std::chrono::milliseconds>(
            sleep, std::chrono::seconds(std::min<std::uint64_t>(*resp.retry_after_s, 3600)));
      if (Clock::now() + sleep >= deadline) fail(std::move(last));
      std::this_thread::sleep_for(sleep);
    }
  }
};

S3Client::S3Client(S3Config config, S3ClientOptions options) {
  ensure_curl_global();
  impl_ = std::make_unique<Impl>(std::move(config), options);
}

S3Client::~S3Client() = default;

const S3Config& S3Client::config() const { return impl_->config; }

std::optional<std::string> S3Client::get(std::string_view bucket, std::string_view key, S3Deadline deadline) {
  check_names("get", bucket, key);
  Impl::Request r(S3Operation::kGet, "GET", bucket, key, impl_->config.url(bucket, key));
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 200) return std::move(resp.body);
  if (resp.status == 404 && parse_error_document(resp.body).code != "NoSuchBucket") return std::nullopt;
  impl_->fail_answer(r, resp);
}

std::optional<std::string> S3Client::get_range(std::string_view bucket, std::string_view key,
                                               std::uint64_t offset, std::uint64_t length, S3Deadline deadline) {
  check_names("get_range", bucket, key);
  if (length == 0) throw std::invalid_argument("S3Client::get_range: an empty range");
  if (offset > UINT64_MAX - length) throw std::invalid_argument("S3Client::get_range: the range overflows");
  const std::uint64_t last = offset + length - 1;
  Impl::Request r(S3Operation::kGetRange, "GET", bucket, key, impl_->config.url(bucket, key));
  r.headers.push_back("Range: bytes=" + std::to_string(offset) + "-" + std::to_string(last));
  r.max_body = length > SIZE_MAX ? SIZE_MAX : std::size_t(length);
  r.ranged = true;
  Response resp = impl_->perform(r, deadline);
  if (resp.range_ignored) {
    resp.body.clear();
    S3Error::Details d = impl_->details(r);
    d.attempts = resp.attempts;
    d.status = 200;
    d.code = "RangeIgnored";
    d.message = "the store answered 200 with the whole object to a request for bytes " + std::to_string(offset) +
                "-" + std::to_string(last);
    impl_->fail(std::move(d));
  }
  if (resp.status == 206) {
    const std::string expected = "bytes " + std::to_string(offset) + "-" + std::to_string(last) + "/";
    if (resp.body_too_long || resp.body.size() != length || !resp.content_range.starts_with(expected)) {
      S3Error::Details d = impl_->details(r);
      d.attempts = resp.attempts;
      d.status = 206;
      d.code = "ShortRange";
      d.message = "asked for bytes " + std::to_string(offset) + "-" + std::to_string(last) + ", got " +
                  (resp.body_too_long ? "more" : std::to_string(resp.body.size())) + " bytes (Content-Range '" +
                  resp.content_range + "')";
      d.request_id = resp.request_id;
      impl_->fail(std::move(d));
    }
    return std::move(resp.body);
  }
  if (resp.status == 404 && parse_error_document(resp.body).code != "NoSuchBucket") return std::nullopt;
  impl_->fail_answer(r, resp);
}

std::optional<S3ObjectInfo> S3Client::head(std::string_view bucket, std::string_view key, S3Deadline deadline) {
  check_names("head", bucket, key);
  Impl::Request r(S3Operation::kHead, "HEAD", bucket, key, impl_->config.url(bucket, key));
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 200) {
    if (!resp.content_length) {
      S3Error::Details d = impl_->details(r);
      d.attempts = resp.attempts;
      d.status = 200;
      d.code = "InvalidResponse";
      d.message = "no Content-Length in the answer";
      impl_->fail(std::move(d));
    }
    return S3ObjectInfo{*resp.content_length, resp.etag, resp.content_type};
  }
  if (resp.status == 404) return std::nullopt;
  impl_->fail_answer(r, resp);
}

std::string S3Client::put(std::string_view bucket, std::string_view key, std::string_view body,
                          std::string_view content_type, S3Deadline deadline) {
  check_names("put", bucket, key);
  Body source;
  source.memory = body;
  source.size = body.size();
  Impl::Request r(S3Operation::kPut, "PUT", bucket, key, impl_->config.url(bucket, key));
  r.payload_sha256 = sha256_hex(body);
  if (!content_type.empty()) r.headers.push_back("Content-Type: " + std::string(content_type));
  r.body = &source;
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 200) return resp.etag;
  impl_->fail_answer(r, resp);
}

std::string S3Client::put_file(std::string_view bucket, std::string_view key, const std::string& path,
                               std::string_view content_type, S3Deadline deadline, std::string_view sha256_hex) {
  check_names("put_file", bucket, key);
  if (!sha256_hex.empty() && !is_sha256_hex(sha256_hex))
    throw std::invalid_argument("S3Client::put_file: sha256_hex is not 64 lower-case hex digits");
  OpenFile file{::open(path.c_str(), O_RDONLY | O_CLOEXEC)};
  if (file.fd < 0) throw std::system_error(errno, std::generic_category(), "S3 put_file: cannot open " + path);
  struct stat st {};
  if (::fstat(file.fd, &st) != 0) throw std::system_error(errno, std::generic_category(), "S3 put_file: " + path);
  if (!S_ISREG(st.st_mode)) throw std::system_error(EINVAL, std::generic_category(), "S3 put_file: not a regular file: " + path);
  if (std::uint64_t(st.st_size) > impl_->options.multipart_threshold)
    return put_multipart(bucket, key, file.fd, std::uint64_t(st.st_size), content_type, deadline);
  Body source;
  source.fd = file.fd;
  source.size = std::uint64_t(st.st_size);
  Impl::Request r(S3Operation::kPutFile, "PUT", bucket, key, impl_->config.url(bucket, key));
  r.payload_sha256 = sha256_hex.empty() ? file_sha256_hex(path) : std::string(sha256_hex);
  if (!content_type.empty()) r.headers.push_back("Content-Type: " + std::string(content_type));
  r.body = &source;
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 200) return resp.etag;
  impl_->fail_answer(r, resp);
}

std::string S3Client::put_multipart(std::string_view bucket, std::string_view key, int fd, std::uint64_t size,
                                    std::string_view content_type, S3Deadline deadline) {
  const std::uint64_t part_bytes = std::max<std::uint64_t>(impl_->options.multipart_part_bytes, 5u << 20);
  if ((size + part_bytes - 1) / part_bytes > 10000)
    throw std::invalid_argument("S3 put_file s3://" + std::string(bucket) + "/" + std::string(key) +
                                ": over 10 000 parts of multipart_part_bytes");
  // A request of the upload: `query` canonical (names sorted), `body` sent as it is.
  auto request = [&](const char* method, const std::string& query, std::string_view body, bool xml) {
    Body source;
    source.memory = body;
    source.size = body.size();
    Impl::Request r(S3Operation::kPutFile, method, bucket, key, impl_->config.url(bucket, key, query));
    r.payload_sha256 = sha256_hex(body);
    if (xml) r.headers.push_back("Content-Type: application/xml");
    else if (!content_type.empty() && query == "uploads=") r.headers.push_back("Content-Type: " + std::string(content_type));
    if (std::strcmp(method, "DELETE") != 0) r.body = &source;
    Response resp = impl_->perform(r, deadline);
    // CompleteMultipartUpload may answer 200 with an <Error> document: a failure all the same.
    if (resp.status != 200 && resp.status != 204) impl_->fail_answer(r, resp);
    if (resp.body.find("<Error>") != std::string::npos) {
      resp.status = 500;
      impl_->fail_answer(r, resp);
    }
    return resp;
  };
  // 1. CreateMultipartUpload.
  std::string upload_id;
  parse_xml(request("POST", "uploads=", "", false).body, [&](const std::string& path, std::string& text) {
    if (path == "InitiateMultipartUploadResult/UploadId") upload_id = text;
  });
  if (upload_id.empty()) throw std::runtime_error("S3 put_file s3://" + std::string(bucket) + "/" + std::string(key) +
                                                  ": the store started a multipart upload without an UploadId");
  const std::string id_param = "uploadId=" + s3_uri_encode(upload_id, false);
  try {
    // 2. UploadPart, one part in memory at a time (its SHA-256 is what the request is signed with).
    std::string complete = "<CompleteMultipartUpload>";
    std::string part;
    for (std::uint64_t start = 0, number = 1; start < size; start += part_bytes, ++number) {
      part.resize(std::size_t(std::min(part_bytes, size - start)));
      for (std::size_t done = 0; done < part.size();) {
        const ssize_t n = ::pread(fd, part.data() + done, part.size() - done, off_t(start + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) throw std::system_error(n < 0 ? errno : EIO, std::generic_category(), "S3 put_file: reading the file");
        done += std::size_t(n);
      }
      const Response resp =
          request("PUT", "partNumber=" + std::to_string(number) + "&" + id_param, part, false);
      complete += "<Part><PartNumber>" + std::to_string(number) + "</PartNumber><ETag>\"" + resp.etag +
                  "\"</ETag></Part>";
    }
    complete += "</CompleteMultipartUpload>";
    // 3. CompleteMultipartUpload: the object appears whole, as with one PUT.
    std::string etag;
    parse_xml(request("POST", id_param, complete, true).body, [&](const std::string& path, std::string& text) {
      if (path == "CompleteMultipartUploadResult/ETag") etag = unquoted(text);
    });
    return etag;
  } catch (...) {
    // AbortMultipartUpload, so that its parts are not billed; a failure here is the lifecycle
    // rule's to mend (docs/s3-operations.md).
    try {
      request("DELETE", id_param, "", false);
    } catch (...) {
    }
    throw;
  }
}

std::string S3Client::copy(std::string_view bucket, std::string_view from_key, std::string_view to_key,
                           S3Deadline deadline) {
  check_names("copy", bucket, from_key);
  check_names("copy", bucket, to_key);
  Body none;  // a PUT without a body, sent with Content-Length: 0
  Impl::Request r(S3Operation::kCopy, "PUT", bucket, to_key, impl_->config.url(bucket, to_key));
  r.headers.push_back("x-amz-copy-source: /" + std::string(bucket) + "/" + s3_uri_encode(from_key, true));
  r.body = &none;
  Response resp = impl_->perform(r, deadline);
  // A copy may answer 200 and then fail: the error is in the body.
  if (resp.status == 200 && resp.body.find("<Error>") != std::string::npos) resp.status = 500;
  if (resp.status != 200) impl_->fail_answer(r, resp);
  std::string etag;
  parse_xml(resp.body, [&](const std::string& path, std::string& text) {
    if (path == "CopyObjectResult/ETag") etag = unquoted(text);
  });
  return etag;
}

void S3Client::remove(std::string_view bucket, std::string_view key, S3Deadline deadline) {
  check_names("remove", bucket, key);
  Impl::Request r(S3Operation::kRemove, "DELETE", bucket, key, impl_->config.url(bucket, key));
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 204 || resp.status == 200) return;
  if (resp.status == 404 && parse_error_document(resp.body).code != "NoSuchBucket") return;
  impl_->fail_answer(r, resp);
}

S3ListPage S3Client::list(std::string_view bucket, std::string_view prefix, std::string_view delimiter,
                          std::string_view continuation, S3Deadline deadline, int max_keys) {
  check_names("list", bucket, prefix, false);
  if (max_keys < 1 || max_keys > 1000) throw std::invalid_argument("S3Client::list: max_keys must be 1-1000");
  // Sorted by name, each value encoded: the canonical query, as libcurl signs what it is given.
  std::string query;
  auto param = [&](std::string_view name, std::string_view value) {
    if (!query.empty()) query += '&';
    query += name;
    query += '=';
    query += s3_uri_encode(value, false);
  };
  if (!continuation.empty()) param("continuation-token", continuation);
  if (!delimiter.empty()) param("delimiter", delimiter);
  param("encoding-type", "url");
  param("list-type", "2");
  param("max-keys", std::to_string(max_keys));
  if (!prefix.empty()) param("prefix", prefix);
  Impl::Request r(S3Operation::kList, "GET", bucket, prefix, impl_->config.url(bucket, "", query));
  Response resp = impl_->perform(r, deadline);
  if (resp.status != 200) impl_->fail_answer(r, resp);

  S3ListPage page;
  S3ListEntry entry;
  bool url_encoded = false;
  bool size_ok = true;
  const bool parsed = parse_xml(resp.body, [&](const std::string& path, std::string& text) {
    if (path == "ListBucketResult/Contents/Key") entry.key = std::move(text);
    else if (path == "ListBucketResult/Contents/Size") {
      auto size = parse_u64(text);
      size_ok = size_ok && size.has_value();
      entry.size = size.value_or(0);
    } else if (path == "ListBucketResult/Contents/ETag") entry.etag = unquoted(text);
    else if (path == "ListBucketResult/Contents") page.objects.push_back(std::exchange(entry, S3ListEntry{}));
    else if (path == "ListBucketResult/CommonPrefixes/Prefix") page.common_prefixes.push_back(std::move(text));
    else if (path == "ListBucketResult/IsTruncated") page.truncated = text == "true";
    else if (path == "ListBucketResult/NextContinuationToken") page.next_continuation = std::move(text);
    else if (path == "ListBucketResult/EncodingType") url_encoded = text == "url";
  });
  if (!parsed || !size_ok || (page.truncated && page.next_continuation.empty())) {
    S3Error::Details d = impl_->details(r);
    d.attempts = resp.attempts;
    d.status = 200;
    d.code = "InvalidResponse";
    d.message = !parsed ? "the listing is not well-formed XML"
                : !size_ok ? "a listed size is not a number"
                           : "a truncated listing without NextContinuationToken";
    d.request_id = resp.request_id;
    impl_->fail(std::move(d));
  }
  // A store that ignores encoding-type says nothing and sends the keys as they are.
  if (url_encoded) {
    for (auto& o : page.objects) o.key = url_decoded(o.key);
    for (auto& p : page.common_prefixes) p = url_decoded(p);
  }
  return page;
}

bool S3Client::create_bucket(std::string_view bucket, S3Deadline deadline) {
  if (!valid_bucket_name(bucket))
    throw std::invalid_argument("S3Client::create_bucket: '" + std::string(bucket) + "' is not a valid bucket name");
  // us-east-1 is the default location and takes no configuration (AWS refuses one naming it).
  std::string configuration;
  if (impl_->config.region() != S3Config::kDefaultRegion)
    configuration = "<CreateBucketConfiguration xmlns=\"http://s3.amazonaws.com/doc/2006-03-01/\"><LocationConstraint>" +
                    impl_->config.region() + "</LocationConstraint></CreateBucketConfiguration>";
  Body source;
  source.memory = configuration;
  source.size = configuration.size();
  Impl::Request r(S3Operation::kCreateBucket, "PUT", bucket, "", impl_->config.url(bucket, ""));
  r.payload_sha256 = sha256_hex(configuration);
  if (!configuration.empty()) r.headers.push_back("Content-Type: application/xml");
  r.body = &source;
  Response resp = impl_->perform(r, deadline);
  if (resp.status == 200) return true;
  if (resp.status == 409 && parse_error_document(resp.body).code == "BucketAlreadyOwnedByYou") return false;
  impl_->fail_answer(r, resp);
}

S3Stats S3Client::stats() const {
  S3Stats s;
  for (std::size_t i = 0; i < kS3OperationCount; ++i) {
    s.requests[i] = impl_->requests[i].load(std::memory_order_relaxed);
    s.failures[i] = impl_->failures[i].load(std::memory_order_relaxed);
  }
  s.retries = impl_->retries.load(std::memory_order_relaxed);
  s.bytes_sent = impl_->bytes_sent.load(std::memory_order_relaxed);
  s.bytes_received = impl_->bytes_received.load(std::memory_order_relaxed);
  return s;
}

}  // namespace zoomwarp::tiles
