// `zoomwarp replay PATH…`: replays view paths (server/view_path.h) against a running server's
// /mesh and /viewport routes with concurrent keep-alive clients, and prints latency percentiles per
// (endpoint, action) and the throughput (server/replay_report.h). For load tests:
// tests/load/README.md has the shipped paths and how to run them. Exit codes: 0 the run completed
// (also when requests failed: the summary counts them), 1 it could not run (server unreachable,
// unknown image), 2 usage or a malformed path, 3 with --fail-on-error when any request failed.
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <charconv>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <regex>
#include <thread>

#include "api/view_methods.h"
#include "server/commands.h"
#include "server/http_client.h"
#include "server/options.h"
#include "server/replay_report.h"
#include "server/view_path.h"
#include "tiles/image_id.h"
#include "warp/window/fit.h"

namespace zoomwarp::server {

namespace replay {

namespace {

using nlohmann::json;
using Clock = std::chrono::steady_clock;

constexpr auto kPauseAfterFailure = std::chrono::milliseconds(100);
constexpr auto kProgressInterval = std::chrono::milliseconds(250);

struct BaseUrl {
  std::string host, port, prefix;  // prefix: "" or "/path", without a trailing slash
};

// The workload (replay_report.h) and how to run it.
struct Config : Workload {
  BaseUrl url;
  std::optional<std::int64_t> count;        // requests per client
  std::optional<Clock::duration> duration;  // instead of a count
  std::string format;
  std::chrono::milliseconds timeout{};
  bool json = false, fail_on_error = false;
};

std::vector<OptionSpec> replay_specs() {
  return {
      {"url", "http://127.0.0.1:8080", "the server, http://HOST[:PORT][/PREFIX]"},
      {"image", "", "id of the image the paths explore (required)"},
      {"clients", "4", "concurrent keep-alive connections; client i of N starts at action i/N of the path"},
      {"count", "", "requests per client, wrapping around the path (default: the path once)"},
      {"duration", "", "seconds to run, wrapping around the path (instead of --count)"},
      {"endpoint", "both", "mesh, viewport, or both (each action requests its mesh, then its viewport)"},
      {"method", "icaz", "any method GET /v1/methods lists; one without a mesh (seam) needs --endpoint viewport"},
      {"fit", "auto", "what zoom 0 does with another aspect ratio: auto, warp, crop or pad (fit= of a view)"},
      {"max-distortion", "", "fit=auto's budget, 1…8 (default: the server's, 1.4)"},
      {"format", "jpg", "viewport image format: jpg, png, webp, avif or jxl"},
      {"timeout", "30", "seconds a request may take before it counts as failed"},
      {"json", "0", "print the summary as one JSON object", true},
      {"fail-on-error", "0", "exit 3 when any request failed", true},
  };
}

constexpr const char* kHelp =
    "usage: zoomwarp replay PATH.jsonl... --image ID [OPTIONS]\n"
    "\n"
    "Replays view paths (JSON lines of zoom and pan actions, see tests/load/README.md) against a\n"
    "running server: every client requests GET /v1/images/ID/mesh and /viewport for each action in\n"
    "turn, as fast as the server answers, on one keep-alive connection (reconnecting after a failure).\n"
    "Several paths are played one after the other. Prints per endpoint and action the requests, the\n"
    "errors (non-2xx answers and connection failures) and the p50/p95/p99 latency of the successful\n"
    "ones, then the throughput. Progress goes to stderr on a terminal.\n"
    "\n"
    "Exit codes: 0 the run completed (even with errors, which the summary reports), 1 it could not\n"
    "run (server unreachable, unknown image), 2 usage or a malformed path, 3 with --fail-on-error\n"
    "when any request failed.\n\n";

BaseUrl parse_url(const std::string& url) {
  static const std::regex form(R"(http://([^/:?#]+)(?::(\d{1,5}))?(/[^?#]*)?)");
  std::smatch m;
  if (!std::regex_match(url, m, form))
    throw std::invalid_argument("--url must look like http://HOST[:PORT][/PREFIX], not '" + url + "'");
  std::string prefix = m[3];
  while (!prefix.empty() && prefix.back() == '/') prefix.pop_back();
  return {m[1], m[2].matched ? m[2].str() : "80", prefix};
}

std::string choice(const Options& o, const std::string& name, const std::vector<std::string>& allowed) {
  const std::string v = o.str(name);
  if (std::find(allowed.begin(), allowed.end(), v) != allowed.end()) return v;
  std::string list;
  for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + a;
  throw std::invalid_argument("--" + name + " must be one of " + list + ", not '" + v + "'");
}

Config config_from(const Options& o) {
  Config c;
  c.url = parse_url(o.str("url"));
  c.image = o.str("image");
  if (c.image.empty()) throw std::invalid_argument("give the image to explore with --image ID (see --help)");
  if (!tiles::is_valid_image_id(c.image)) throw std::invalid_argument("invalid image id '" + c.image + "'");
  c.clients = int(o.integer("clients", 1, 1024));
  if (!o.str("count").empty() && !o.str("duration").empty())
    throw std::invalid_argument("give --count or --duration, not both");
  if (!o.str("count").empty()) c.count = o.integer("count", 1, 1'000'000'000);
  if (!o.str("duration").empty()) c.duration = std::chrono::seconds(o.integer("duration", 1, 86400));
  const std::string endpoint = choice(o, "endpoint", {"mesh", "viewport", "both"});
  if (endpoint != "viewport") c.endpoints.push_back(Endpoint::kMesh);
  if (endpoint != "mesh") c.endpoints.push_back(Endpoint::kViewport);
  c.method = o.str("method");
  // Every method a view may name, from the same table as GET /v1/methods (api/view_methods.h).
  const api::ViewMethod* method = api::find_view_method(c.method);
  if (!method) {
    std::string names;
    for (const api::ViewMethod& m : api::view_methods()) names += (names.empty() ? "" : ", ") + std::string(m.name());
    throw std::invalid_argument("--method must be one of " + names + ", not '" + c.method + "'");
  }
  if (!method->description.has_mesh && endpoint != "viewport")
    throw std::invalid_argument("--method " + c.method + " has no mesh (GET /v1/methods): replay it with --endpoint viewport");
  c.fit = choice(o, "fit", {"auto", "warp", "crop", "pad"});
  c.max_distortion = o.str("max-distortion");
  if (!c.max_distortion.empty()) {
    char* end = nullptr;
    const double v = std::strtod(c.max_distortion.c_str(), &end);
    if (*end != 0 || !(v >= warp::kMinMaxDistortion && v <= warp::kMaxMaxDistortion))
      throw std::invalid_argument("--max-distortion must be a number from 1 to 8, not '" + c.max_distortion + "'");
  }
  c.format = choice(o, "format", {"jpg", "png", "webp", "avif", "jxl"});
  c.timeout = std::chrono::seconds(o.integer("timeout", 1, 3600));
  c.json = o.flag("json");
  c.fail_on_error = o.flag("fail-on-error");
  c.paths = o.positionals();
  if (c.paths.empty()) throw std::invalid_argument("give at least one view path file (see --help)");
  return c;
}

std::vector<ViewAction> read_paths(const std::vector<std::string>& files) {
  std::vector<ViewAction> actions;
  for (const auto& f : files) {
    auto more = read_view_path(f);
    actions.insert(actions.end(), more.begin(), more.end());
  }
  return actions;
}

// The server reads plain decimals only, no exponent: the shortest fixed notation that reads back
// as the same number.
std::string decimal(double v) {
  char buf[400];  // DBL_MAX in fixed notation has 309 digits
  return std::string(buf, std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed).ptr);
}

// "/v1/images/{id}" under the URL's prefix.
std::string image_target(const Config& c) { return c.url.prefix + "/v1/images/" + c.image; }

struct ImageSize {
  double width = 0, height = 0;
};

// The image's size from GET /v1/images/{id}; also proves the server is there before the clients
// start. Throws std::runtime_error (exit 1) when it cannot tell.
ImageSize image_size(const Config& c) {
  HttpClient http(c.url.host, c.url.port, c.timeout);
  const std::string target = image_target(c);
  HttpClientResponse r = http.get(target);
  while (!r.body.empty() && std::isspace(static_cast<unsigned char>(r.body.back()))) r.body.pop_back();
  if (r.status != 200)
    throw std::runtime_error("GET " + target + " answered " + std::to_string(r.status) + ": " + r.body);
  const json j = json::parse(r.body, nullptr, /*allow_exceptions=*/false);
  if (!j.is_object() || !j.value("width", json()).is_number() || !j.value("height", json()).is_number())
    throw std::runtime_error("GET " + target + " does not describe an image: " + r.body);
  return {j["width"].get<double>(), j["height"].get<double>()};
}

// The server refuses view centres outside the image: say so once, pointing at the line, rather
// than replaying a path made for another image as a stream of 400s.
void check_fits(const std::vector<ViewAction>& actions, ImageSize size, const std::string& image) {
  for (const auto& a : actions)
    if (a.cx > size.width || a.cy > size.height)
      throw std::invalid_argument(a.where + ": the view centre (" + decimal(a.cx) + ", " + decimal(a.cy) +
                                  ") lies outside image " + image + " (" + decimal(size.width) + "x" +
                                  decimal(size.height) + ")");
}

struct PlannedRequest {
  int series = 0;
  std::string target;
};

// Every request of one pass over the path, action by action, in endpoint order.
std::vector<PlannedRequest> plan_requests(const std::vector<ViewAction>& actions, const Config& c) {
  std::vector<PlannedRequest> plan;
  for (const auto& a : actions) {
    const std::string query = "?zoom=" + decimal(a.zoom) + "&cx=" + decimal(a.cx) + "&cy=" + decimal(a.cy) +
                              "&w=" + std::to_string(a.width) + "&h=" + std::to_string(a.height) +
                              "&method=" + c.method + "&fit=" + c.fit +
                              (c.max_distortion.empty() ? "" : "&max_distortion=" + c.max_distortion);
    for (Endpoint e : c.endpoints)
      plan.push_back({series_of(e, a.kind), image_target(c) + "/" + kEndpointNames[int(e)] + query +
                                                (e == Endpoint::kViewport ? "&format=" + c.format : "")});
  }
  return plan;
}

// What the clients share while they run.
struct Run {
  explicit Run(const std::vector<PlannedRequest>& p) : plan(p) {}
  const std::vector<PlannedRequest>& plan;
  std::int64_t per_client = 0;            // requests each client makes, without a deadline
  std::optional<Clock::time_point> deadline;
  std::atomic<std::int64_t> done{0}, failed{0};
  std::mutex mu;  // guards what follows
  std::condition_variable finished;
  int running = 0;
  std::string first_connection_error;
};

struct Outcome {
  int status = 0;  // 0: no answer
  double ms = 0;
};

Outcome timed_get(HttpClient& http, const std::string& target, Run& run) {
  const auto t0 = Clock::now();
  Outcome out;
  std::optional<std::string> failure;
  try {
    out.status = http.get(target).status;
  } catch (const HttpClientError& e) {
    failure = e.what();
  }
  out.ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  if (failure) {
    {
      std::lock_guard lock(run.mu);
      if (run.first_connection_error.empty()) run.first_connection_error = *failure;
    }
    // The next get() reconnects; the pause keeps an unreachable server from turning the client
    // into a busy loop of refused connections.
    std::this_thread::sleep_for(kPauseAfterFailure);
  }
  return out;
}

// One client: its own connection, walking the plan from `start` and wrapping around. A reconnect
// counts in the latency of the request that needed it, as a viewer would feel it.
Tally replay_client(Run& run, const Config& c, std::size_t start) {
  HttpClient http(c.url.host, c.url.port, c.timeout);
  Tally tally;
  for (std::int64_t i = 0; run.deadline ? Clock::now() < *run.deadline : i < run.per_client; ++i) {
    const PlannedRequest& r = run.plan[(start + i) % run.plan.size()];
    const Outcome o = timed_get(http, r.target, run);
    tally.record(r.series, o.status, o.ms);
    if (!succeeded(o.status)) ++run.failed;
    ++run.done;
  }
  return tally;
}

void draw_progress(const Run& run, const Config& c, double elapsed_s) {
  const auto done = run.done.load();
  if (c.duration)
    std::fprintf(stderr, "\rreplay: %.1f/%.0f s, %lld requests", elapsed_s,
                 std::chrono::duration<double>(*c.duration).count(), (long long)done);
  else
    std::fprintf(stderr, "\rreplay: %lld/%lld requests", (long long)done, (long long)(run.per_client * c.clients));
  std::fprintf(stderr, ", %lld failed, %.1f/s ", (long long)run.failed.load(), elapsed_s > 0 ? done / elapsed_s : 0.0);
  std::fflush(stderr);
}

// Client i of N starts at action ⌊i·n/N⌋ so that the clients ask for different views at the same
// moment; all starting together would mostly measure the server's single flight and response
// cache, not its warps.
Summary run_clients(const std::vector<PlannedRequest>& plan, std::size_t actions, const Config& c) {
  Run run(plan);
  run.per_client = c.count.value_or(std::int64_t(plan.size()));
  run.running = c.clients;
  const auto t0 = Clock::now();
  if (c.duration) run.deadline = t0 + *c.duration;
  std::vector<Tally> tallies(c.clients);
  std::vector<std::thread> threads;
  for (int i = 0; i < c.clients; ++i)
    threads.emplace_back([&, i] {
      tallies[i] = replay_client(run, c, (i * actions / c.clients) * c.endpoints.size());
      std::lock_guard lock(run.mu);
      --run.running;
      run.finished.notify_all();
    });
  const bool progress = ::isatty(STDERR_FILENO);
  {
    std::unique_lock lock(run.mu);
    while (!run.finished.wait_for(lock, kProgressInterval, [&] { return run.running == 0; }))
      if (progress) draw_progress(run, c, std::chrono::duration<double>(Clock::now() - t0).count());
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  for (auto& t : threads) t.join();
  if (progress) {
    draw_progress(run, c, seconds);
    std::fputc('\n', stderr);
  }
  return summarize(tallies, seconds, run.first_connection_error);
}

// The paths the flags name replayed, the summary printed; the exit code.
int replay_paths(const Options& o) {
  const Config c = config_from(o);
  const std::vector<ViewAction> actions = read_paths(c.paths);
  check_fits(actions, image_size(c), c.image);
  const Summary s = run_clients(plan_requests(actions, c), actions.size(), c);
  if (c.json) print_summary_json(s, c);
  else print_summary(s, c, actions.size());
  return c.fail_on_error && s.errors > 0 ? 3 : 0;
}

}  // namespace

}  // namespace replay

int replay_command(const std::vector<std::string>& args) {
  return run_command("replay", [&]() -> int {
    Options o(replay::replay_specs(), args);
    if (o.help_requested()) {
      std::printf("%s%s", replay::kHelp, o.usage().c_str());
      return 0;
    }
    return replay::replay_paths(o);
  });
}

}  // namespace zoomwarp::server
