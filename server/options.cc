#include "server/options.h"

#include <cctype>
#include <cstdlib>
#include <stdexcept>

namespace zoomwarp::server {

std::string Options::env_name(const std::string& option) {
  std::string env = "ZOOMWARP_";
  for (char c : option) env.push_back(c == '-' ? '_' : char(std::toupper(static_cast<unsigned char>(c))));
  return env;
}

Options::Options(std::vector<OptionSpec> specs, const std::vector<std::string>& args)
    : specs_(std::move(specs)) {
  for (const auto& s : specs_) {
    values_[s.name] = s.fallback;
    if (const char* env = std::getenv(env_name(s.name).c_str())) values_[s.name] = env;
  }
  auto find = [&](const std::string& name) -> const OptionSpec& {
    for (const auto& s : specs_)
      if (s.name == name) return s;
    throw std::invalid_argument("unknown option --" + name + " (see --help)");
  };
  for (std::size_t i = 0; i < args.size(); ++i) {
    const std::string& a = args[i];
    if (a == "-h" || a == "--help") {
      help_ = true;
      continue;
    }
    if (a.size() < 3 || a.rfind("--", 0) != 0) {
      positionals_.push_back(a);
      continue;
    }
    std::string name = a.substr(2), value;
    const bool inline_value = name.find('=') != std::string::npos;
    if (inline_value) {
      value = name.substr(name.find('=') + 1);
      name = name.substr(0, name.find('='));
    }
    const OptionSpec& spec = find(name);
    if (spec.is_switch) {
      values_[name] = inline_value ? value : "1";
    } else if (inline_value) {
      values_[name] = value;
    } else {
      if (i + 1 >= args.size()) throw std::invalid_argument("option --" + name + " needs a value");
      values_[name] = args[++i];
    }
  }
}

std::string Options::str(const std::string& name) const { return values_.at(name); }

std::int64_t Options::integer(const std::string& name, std::int64_t lo, std::int64_t hi) const {
  const std::string& v = values_.at(name);
  std::size_t used = 0;
  long long n = 0;
  try {
    n = std::stoll(v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  if (v.empty() || used != v.size() || n < lo || n > hi)
    throw std::invalid_argument("--" + name + " (" + env_name(name) + ") must be a whole number from " +
                                std::to_string(lo) + " to " + std::to_string(hi) + ", not '" + v + "'");
  return n;
}

std::uint64_t Options::bytes(const std::string& name, std::uint64_t lo, std::uint64_t hi) const {
  std::string v = values_.at(name);
  std::uint64_t mult = 1;
  if (!v.empty()) {
    switch (std::toupper(static_cast<unsigned char>(v.back()))) {
      case 'K': mult = 1ULL << 10; break;
      case 'M': mult = 1ULL << 20; break;
      case 'G': mult = 1ULL << 30; break;
    }
    if (mult != 1) v.pop_back();
  }
  std::size_t used = 0;
  unsigned long long n = 0;
  try {
    n = v.empty() || v[0] == '-' ? 0 : std::stoull(v, &used, 10);
  } catch (const std::exception&) {
    used = 0;
  }
  const std::uint64_t total = n * mult;
  if (v.empty() || used != v.size() || (mult > 1 && n > hi / mult) || total < lo || total > hi)
    throw std::invalid_argument("--" + name + " (" + env_name(name) + ") must be a size such as 512M from " +
                                std::to_string(lo) + " to " + std::to_string(hi) + " bytes, not '" +
                                values_.at(name) + "'");
  return total;
}

bool Options::flag(const std::string& name) const {
  const std::string& v = values_.at(name);
  if (v == "1" || v == "true" || v == "yes" || v == "on") return true;
  if (v == "0" || v == "false" || v == "no" || v == "off" || v.empty()) return false;
  throw std::invalid_argument("--" + name + " (" + env_name(name) + ") must be 1/0, true/false, not '" + v + "'");
}

std::string Options::usage() const {
  std::string out;
  for (const auto& s : specs_) {
    std::string left = "  --" + s.name + (s.is_switch ? "" : " VALUE");
    if (left.size() < 28) left.resize(28, ' ');
    out += left + " " + s.help + "\n" + std::string(29, ' ') + "[" + env_name(s.name) +
           (s.fallback.empty() ? "" : "; default " + s.fallback) + "]\n";
  }
  return out;
}

}  // namespace zoomwarp::server
