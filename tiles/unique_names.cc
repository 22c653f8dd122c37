#include "tiles/unique_names.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <random>

namespace zoomwarp::tiles {

std::string hex(std::uint64_t v, int digits) {
  static const char* d = "0123456789abcdef";
  std::string s(digits, '0');
  for (int i = digits - 1; i >= 0; --i, v >>= 4) s[i] = d[v & 15];
  return s;
}

std::uint64_t random_u64() {
  static thread_local std::mt19937_64 rng{std::random_device{}() ^ std::uint64_t(::getpid()) << 32 ^
                                          std::uint64_t(std::chrono::steady_clock::now().time_since_epoch().count())};
  return rng();
}

std::string host_name() {
  char buf[256] = {};
  if (::gethostname(buf, sizeof buf - 1) != 0) return "host";
  std::string h(buf);
  std::replace(h.begin(), h.end(), '.', '_');
  return h;
}

std::string owned_unique_name() { return host_name() + "." + std::to_string(::getpid()) + "." + hex(random_u64(), 12); }

}  // namespace zoomwarp::tiles
