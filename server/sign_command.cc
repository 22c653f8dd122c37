// `zoomwarp sign URL --expires 1h [--signing-key FILE]`: prints URL signed for a private image
// (api/url_signing.h) with the server's signing secret, valid for the given time from now. The
// URL may be absolute (http://host/…) or a path; only its path and query are signed, so a link
// signed for one host name works behind another that forwards the same path.
#include <chrono>
#include <cstdio>

#include "api/url_signing.h"
#include "server/commands.h"
#include "server/options.h"

namespace zoomwarp::server {

namespace {

constexpr const char* kHelp =
    "usage: zoomwarp sign URL [OPTIONS]\n"
    "\n"
    "Prints URL with expires= and sig= added: a link to a private image that works without an API\n"
    "key until it expires. URL is absolute (http://host/iiif/3/ID/info.json) or a path\n"
    "(/dzi/ID.dzi); path and query are signed, so the link cannot be changed into another.\n"
    "The server must run with the same --signing-key.\n\n";

// "90", "90s", "15m", "1h", "7d" → seconds; at most a year.
std::int64_t parse_duration(const std::string& text) {
  std::size_t digits = 0;
  while (digits < text.size() && text[digits] >= '0' && text[digits] <= '9') ++digits;
  const std::string unit = text.substr(digits);
  const std::int64_t scale = unit.empty() || unit == "s" ? 1 : unit == "m" ? 60 : unit == "h" ? 3600 : unit == "d" ? 86400 : 0;
  if (digits == 0 || digits > 9 || scale == 0)
    throw std::invalid_argument("--expires must be a duration such as 30s, 15m, 1h or 7d, not '" + text + "'");
  const std::int64_t seconds = std::stoll(text.substr(0, digits)) * scale;
  if (seconds <= 0 || seconds > 366 * 86400) throw std::invalid_argument("--expires must be between 1s and 366d");
  return seconds;
}

// Splits "http://host:8080/p?q" into "http://host:8080", "/p" and "q".
struct UrlParts {
  std::string origin, path, query;
};
UrlParts split_url(const std::string& url) {
  std::size_t path_start = 0;
  if (const std::size_t scheme = url.find("://"); scheme != std::string::npos) path_start = url.find('/', scheme + 3);
  if (path_start == std::string::npos || url.compare(path_start, 1, "/") != 0 || url.find('#') != std::string::npos)
    throw std::invalid_argument("URL must be http(s)://HOST/PATH[?QUERY] or /PATH[?QUERY], without a fragment");
  const std::size_t q = url.find('?', path_start);
  return {url.substr(0, path_start), url.substr(path_start, q - path_start),
          q == std::string::npos ? "" : url.substr(q + 1)};
}

}  // namespace

int sign_command(const std::vector<std::string>& args) {
  return run_command("sign", [&]() -> int {
    Options o({{"expires", "1h", "how long the URL stays valid: 30s, 15m, 1h, 7d"},
               {"signing-key", "", "file holding the signing secret (the server's --signing-key)"}},
              args);
    if (o.help_requested()) {
      std::printf("%s%s", kHelp, o.usage().c_str());
      return 0;
    }
    if (o.positionals().size() != 1) throw std::invalid_argument("give exactly one URL to sign (see --help)");
    if (o.str("signing-key").empty()) throw std::invalid_argument("--signing-key (or ZOOMWARP_SIGNING_KEY) is required");
    const std::int64_t lifetime = parse_duration(o.str("expires"));
    const auto signer = api::UrlSigner::from_file(o.str("signing-key"));
    const UrlParts url = split_url(o.positionals()[0]);
    const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
    std::printf("%s%s\n", url.origin.c_str(), signer.sign(url.path, url.query, now.count() + lifetime).c_str());
    return 0;
  });
}

}  // namespace zoomwarp::server
