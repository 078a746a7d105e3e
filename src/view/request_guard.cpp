#include <gshell/view/request_guard.h>

#include <algorithm>
#include <cctype>

namespace gshell {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

} // namespace

RequestGuard::RequestGuard(const std::string& bound_host, int port) {
  std::vector<std::string> names{"localhost", "127.0.0.1", "[::1]"};
  std::string bound = lower(bound_host);
  if (bound.find(':') != std::string::npos && bound.front() != '[') bound = "[" + bound + "]"; // IPv6 literal
  if (!bound.empty() && std::find(names.begin(), names.end(), bound) == names.end()) names.push_back(bound);
  for (const std::string& name : names) {
    hosts_.push_back(name + ":" + std::to_string(port));
    if (port == 80) hosts_.push_back(name);
  }
}

bool RequestGuard::host_allowed(std::string_view host) const {
  const std::string h = lower(host);
  return std::find(hosts_.begin(), hosts_.end(), h) != hosts_.end();
}

bool RequestGuard::origin_allowed(std::string_view origin, bool present) const {
  if (!present) return true; // not a browser: the Origin check protects browsers' users only
  const std::string o = lower(origin);
  const std::string scheme = "http://";
  return o.size() > scheme.size() && o.compare(0, scheme.size(), scheme) == 0 && host_allowed(o.substr(scheme.size()));
}

} // namespace gshell
