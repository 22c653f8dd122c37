#include "tiles/bucket_lease.h"

#include <algorithm>
#include <charconv>
#include <thread>

#include "tiles/unique_names.h"

namespace zoomwarp::tiles {

namespace {

std::int64_t unix_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace

std::string lease_text(const HeldLease& held) { return held.token + " " + std::to_string(held.expires_ms) + "\n"; }

std::optional<HeldLease> parse_lease(const std::string& text) {
  const std::size_t space = text.find(' ');
  if (space == 0 || space == std::string::npos) return std::nullopt;
  HeldLease out;
  out.token = text.substr(0, space);
  std::string_view rest(text);
  rest.remove_prefix(space + 1);
  while (!rest.empty() && (rest.back() == '\n' || rest.back() == ' ')) rest.remove_suffix(1);
  const auto [end, ec] = std::from_chars(rest.data(), rest.data() + rest.size(), out.expires_ms);
  if (ec != std::errc() || end != rest.data() + rest.size()) return std::nullopt;
  return out;
}

std::chrono::milliseconds lease_time_left(const HeldLease& held, const LeaseTiming& timing) {
  return std::chrono::milliseconds(held.expires_ms - unix_ms()) - timing.skew;
}

HeldLease acquire_lease(const LeaseObject& lease, const LeaseTiming& timing,
                        std::chrono::steady_clock::time_point deadline) {
  using Clock = std::chrono::steady_clock;
  std::string last_holder;
  for (;;) {
    // 1. Someone else's live lease: wait for its release or its expiry.
    if (const std::optional<std::string> text = lease.get()) {
      const std::optional<HeldLease> other = parse_lease(*text);
      // A damaged lease is nobody's: taken over as an expired one.
      if (other && unix_ms() < other->expires_ms + timing.skew.count()) {
        last_holder = other->token;
        const auto wait = std::min<Clock::duration>(timing.poll, std::chrono::milliseconds(other->expires_ms +
                                                                                           timing.skew.count() - unix_ms()));
        if (Clock::now() + wait >= deadline)
          throw LeaseBusy("held by " + other->token + " until " + std::to_string(other->expires_ms), other->token);
        std::this_thread::sleep_for(std::max<Clock::duration>(wait, std::chrono::milliseconds(1)));
        continue;
      }
    }
    // 2. Ours, with a token no other acquisition uses (not written without the time to settle it:
    //    a lease left behind would hold the others up for `ttl`).
    if (Clock::now() + timing.settle >= deadline)
      throw LeaseBusy("no time left to settle a lease", last_holder);
    HeldLease mine{owned_unique_name(), unix_ms() + timing.ttl.count()};
    lease.put(lease_text(mine));
    // 3. Still ours after `settle`: no other process can also read its own.
    std::this_thread::sleep_for(timing.settle);
    const std::optional<std::string> after = lease.get();
    const std::optional<HeldLease> now = after ? parse_lease(*after) : std::nullopt;
    if (now && now->token == mine.token) return mine;
    if (now) last_holder = now->token;
  }
}

void release_lease(const LeaseObject& lease, const HeldLease& held, const LeaseTiming& timing) {
  if (lease_time_left(held, timing) <= std::chrono::milliseconds(0)) return;
  try {
    lease.remove();
  } catch (...) {
  }
}

}  // namespace zoomwarp::tiles
