// A client connection on plain POSIX sockets for tests that need what a library client hides:
// sending malformed or pipelined bytes, pausing or hanging up mid-request, reading one response
// while keeping the connection open, connecting while the server is not accepting, and telling
// "the server closed the connection" apart from "nothing came". Header-only; used by the HTTP
// tests in this folder.
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <new>
#include <stdexcept>
#include <string>
#include <string_view>

namespace zoomwarp::testing {

class RawConnection {
 public:
  // Connects to 127.0.0.1:port; throws std::runtime_error if it cannot.
  explicit RawConnection(int port) {
    if (!connect_to(port)) {
      close();
      throw std::runtime_error("cannot connect to port " + std::to_string(port));
    }
  }
  // Connects to 127.0.0.1:port without throwing: `connected()` tells whether it did (for tests
  // that assert on it, e.g. that the kernel completes connections the server has not accepted).
  RawConnection(int port, std::nothrow_t) { connected_ = connect_to(port); }
  ~RawConnection() { close(); }
  RawConnection(const RawConnection&) = delete;
  RawConnection& operator=(const RawConnection&) = delete;

  bool connected() const { return connected_; }

  // Sends all of `bytes`; throws std::runtime_error if it cannot.
  void send(std::string_view bytes) {
    if (!try_send(bytes)) throw std::runtime_error("send failed");
  }
  // Sends all of `bytes`; false if it cannot, e.g. once the server has closed (or reset) the
  // connection.
  bool try_send(std::string_view bytes) {
    return ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL) == ssize_t(bytes.size());
  }

  // Whether something (bytes or the end of the stream) arrives within `timeout_ms`.
  bool readable(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    return ::poll(&p, 1, timeout_ms) > 0;
  }

  struct Received {
    std::string bytes;
    bool closed = false;  // the server closed the connection (end of stream or reset)
  };

  // Reads until the server closes the connection or `timeout_ms` has passed.
  Received read_until_close(int timeout_ms) {
    Received r;
    const auto deadline = deadline_in(timeout_ms);
    while (true) {
      if (!readable_before(deadline)) return r;
      char buf[64 * 1024];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) {
        r.closed = true;
        return r;
      }
      r.bytes.append(buf, std::size_t(n));
    }
  }

  // Reads one response, head and body (Content-Length framed), leaving the connection open; what
  // has arrived when the server closes the connection or `timeout_ms` has passed, if less.
  std::string read_response(int timeout_ms) {
    std::string out;
    const auto deadline = deadline_in(timeout_ms);
    while (!complete(out)) {
      if (!readable_before(deadline)) break;
      char buf[64 * 1024];
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) break;
      out.append(buf, std::size_t(n));
    }
    return out;
  }

  // The client giving up: closes the socket at once.
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }

 private:
  // Opens the socket and connects it; on failure the socket is left open (unconnected), as a
  // client's would be.
  bool connect_to(int port) {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(std::uint16_t(port));
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    return fd_ >= 0 && ::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0;
  }

  static std::chrono::steady_clock::time_point deadline_in(int timeout_ms) {
    return std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  }

  // Whether something arrives before `deadline`.
  bool readable_before(std::chrono::steady_clock::time_point deadline) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()).count();
    return left > 0 && readable(int(left));
  }

  // Whether `r` holds a whole response: its head and as many body bytes as its Content-Length.
  static bool complete(const std::string& r) {
    const auto end = r.find("\r\n\r\n");
    if (end == std::string::npos) return false;
    const auto cl = r.find("Content-Length: ");
    const std::size_t length = cl < end ? std::stoul(r.substr(cl + 16)) : 0;
    return r.size() >= end + 4 + length;
  }

  int fd_ = -1;
  bool connected_ = true;  // only the std::nothrow constructor can leave it false
};

// How many times `needle` occurs in `haystack`.
inline int count_of(std::string_view haystack, std::string_view needle) {
  int n = 0;
  for (std::size_t at = haystack.find(needle); at != std::string_view::npos; at = haystack.find(needle, at + 1)) ++n;
  return n;
}

}  // namespace zoomwarp::testing
