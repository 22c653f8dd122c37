#include "api/cached_responses.h"

#include <future>
#include <utility>

#include "api/errors.h"
#include "api/http_caching.h"

namespace zoomwarp::api {

namespace {

// The failure cache's memory: a remembered failure is its key and a ~150-byte error body, so this
// holds a few thousand; a flood of distinct failing requests only evicts older ones.
constexpr std::size_t kFailureCacheBytes = 1u << 20;

}  // namespace

CachedResponses::CachedResponses(Options options)
    : options_(std::move(options)),
      cache_(options_.cache_bytes),
      failures_(options_.failure_window, kFailureCacheBytes) {}

std::optional<Response> CachedResponses::image_response(const Request& req, const tiles::ImageEntry& entry,
                                               const std::string& route, const std::string& key_extra,
                                               bool may_compute,
                                               const std::function<Response(const tiles::ImageEntry&)>& compute) {
  const tiles::Manifest& m = entry.manifest;
  const std::string key = req.path + "|" + key_extra;
  // Made only where needed: a cache hit carries its own (one string and one hash fewer per hit).
  auto with_validators = [&](Response r) {
    r.route = route;
    r.set_header("ETag", make_etag(m.version, key));
    r.set_header("Last-Modified", http_date(m.created_ms));
    // A private image's answers are for this client only: a shared cache (nginx) must not keep them.
    r.set_header("Cache-Control", std::string(m.is_private ? "private" : "public") +
                                      ", max-age=" + std::to_string(options_.cache_max_age));
    return r;
  };
  if (!req.if_none_match.empty() && if_none_match_matches(req.if_none_match, make_etag(m.version, key))) {
    Response r;
    r.status = 304;
    return with_validators(std::move(r));
  }
  const std::string cache_key = m.version + "|" + key;
  if (auto hit = cache_.get(cache_key)) {
    Response r = *hit;
    r.cache = "hit";
    return r;
  }
  if (auto failed = failures_.get(cache_key)) {
    failed->route = route;
    return failed;
  }
  if (!may_compute) return std::nullopt;
  try {
    return compute_once(cache_key, req.stop, [&] {
      if (options_.compute_hook) options_.compute_hook(req);
      return with_validators(compute(entry));
    });
  } catch (...) {
    auto failed = server_failure_response(std::current_exception());
    if (!failed) throw;
    failed->route = route;
    return failed;
  }
}

namespace {
// Waits for another request's computation as long as `stop` allows; throws Stopped when it ends.
void wait_for(const std::shared_future<std::shared_ptr<const Response>>& pending, const warp::StopToken* stop) {
  if (!stop) return pending.wait();
  while (pending.wait_for(std::chrono::milliseconds(20)) != std::future_status::ready) stop->check();
}
}  // namespace

Response CachedResponses::compute_remembering_failure(const std::string& cache_key, const std::function<Response()>& compute) {
  try {
    return compute();
  } catch (...) {
    // Not a request that was cancelled (its client left: nothing is wrong with the view), nor the
    // client's own error (as cheap to find again as to remember), nor the store's (nothing is
    // wrong with the view either; while the store is known down, asking it costs nothing, and the
    // view is served again as soon as it answers).
    const auto failed = server_failure_response(std::current_exception());
    if (failed && failed->failure != "cancelled" && failed->failure != "store") failures_.put(cache_key, *failed);
    throw;
  }
}

Response CachedResponses::compute_once(const std::string& cache_key, const warp::StopToken* stop,
                              const std::function<Response()>& compute) {
  while (true) {
    warp::check_stop(stop);  // out of time or cancelled while queued: not computed at all
    // Single flight: the first request for a key computes, identical ones arriving meanwhile wait
    // for its answer (a burst of clients opening the same view costs one warp and one encode).
    bool computing = false;
    try {
      const auto [answer, computed] = in_flight_.get(
          cache_key,
          [&] {
            computing = true;
            auto r = std::make_shared<const Response>(compute_remembering_failure(cache_key, compute));
            // Cached before the flight lands, so that a request arriving after it finds the answer.
            if (r->status == 200) cache_.put(cache_key, r, r->body->size());
            return r;
          },
          [&](const auto& pending) { wait_for(pending, stop); });  // a waiter that runs out of time leaves
      Response r = *answer;
      r.cache = computed ? "miss" : "hit";
      return r;
    } catch (const warp::Stopped&) {
      if (computing) throw;
      warp::check_stop(stop);  // this request's own time ran out, or its client left, while waiting
      // The computing request's own client left or it ran out of time: not ours; compute it here.
    }
  }
}

}  // namespace zoomwarp::api
