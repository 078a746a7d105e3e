#include <gshell/view/request_guard.h>

#include <arpa/inet.h>

#include <algorithm>
#include <cctype>

namespace gshell {

namespace {

std::string lower(std::string_view s) {
  std::string out(s);
  std::transform(out.begin(), out.end(), out.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return out;
}

// An IP address written out: "192.0.2.2" or "[fd00::2]". DNS rebinding needs a name to rebind.
bool is_ip_literal(const std::string& host) {
  unsigned char address[16];
  if (host.size() > 2 && host.front() == '[' && host.back() == ']')
    return inet_pton(AF_INET6, host.substr(1, host.size() - 2).c_str(), address) == 1;
  return inet_pton(AF_INET, host.c_str(), address) == 1;
}

} // namespace

RequestGuard::RequestGuard(const std::string& bound_host, int port) {
  const std::string wildcard = lower(bound_host);
  any_address_ = wildcard == "0.0.0.0" || wildcard == "::" || wildcard == "[::]";
  port_ = port;
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
  if (std::find(hosts_.begin(), hosts_.end(), h) != hosts_.end()) return true;
  if (!any_address_) return false;
  // Bound to every interface: any of the machine's addresses may be in the Host header, and an
  // address cannot be rebound, so every IP literal with this server's port is accepted.
  std::string suffix(1, ':'); // not ":" + ...: GCC 12 warns of a false -Wrestrict there
  suffix += std::to_string(port_);
  if (h.size() > suffix.size() && h.compare(h.size() - suffix.size(), suffix.size(), suffix) == 0)
    return is_ip_literal(h.substr(0, h.size() - suffix.size()));
  return port_ == 80 && is_ip_literal(h);
}

bool RequestGuard::origin_allowed(std::string_view origin, bool present) const {
  if (!present) return true; // not a browser: the Origin check protects browsers' users only
  const std::string o = lower(origin);
  const std::string scheme = "http://";
  return o.size() > scheme.size() && o.compare(0, scheme.size(), scheme) == 0 && host_allowed(o.substr(scheme.size()));
}

} // namespace gshell
