#pragma once
// Which requests `gshell view` answers. A page on any web site can make the browser send requests
// to 127.0.0.1, and with DNS rebinding (evil.example resolving to 127.0.0.1) even read the
// answers; the browser always says which site it thinks it is talking to (Host) and, for
// WebSockets, which site the script came from (Origin). So the server answers only requests whose
// Host names it (its bound address or localhost, with its port), and accepts WebSocket upgrades
// only without an Origin (not a browser) or from its own pages. Bound to every interface, a request
// may name any of the machine's addresses: IP addresses are accepted then (a rebound name is not).
#include <string>
#include <string_view>
#include <vector>

namespace gshell {

class RequestGuard {
public:
  /// `bound_host` as the user gave it (e.g. "127.0.0.1", "::1", "0.0.0.0", "myhost"), `port` the
  /// port actually bound.
  RequestGuard(const std::string& bound_host, int port);

  /// Host header (case-insensitive): "localhost", "127.0.0.1", "[::1]" or the bound host, each
  /// with ":PORT" (without it only when the port is 80, as browsers send it then). Bound to every
  /// interface ("0.0.0.0", "::"), also any IP address ("192.0.2.2:PORT", "[fd00::2]:PORT"): the
  /// machine's own addresses, which a rebound name cannot pose as.
  bool host_allowed(std::string_view host) const;
  /// Origin header of a WebSocket upgrade: absent (empty) or "http://" + an allowed Host.
  bool origin_allowed(std::string_view origin, bool present) const;

  /// The Host values allowed, for messages.
  const std::vector<std::string>& hosts() const { return hosts_; }

private:
  std::vector<std::string> hosts_; ///< lower case, with port (and without, for port 80)
  bool any_address_ = false;       ///< bound to every interface
  int port_ = 0;
};

} // namespace gshell
