#pragma once
// The server of `gshell view`: HTTP for the page (embedded at build time, view/web_assets) and one
// WebSocket per open page, both on one port (Boost.Beast), around a ViewSession.
//
// Threads:
//  - the network thread (the caller of run()) accepts connections, serves files, reads page
//    messages and writes what the session sends (per page a queue; a positions or values frame
//    still waiting replaces its older twin, so a slow page gets the latest state, not a backlog);
//  - the solver thread owns the ViewSession: it applies page messages in order, solves one drag
//    event for the latest targets (drags that arrived meanwhile coalesce), and when the mouse
//    rests (no drag for rest_seconds, or a release) settles to convergence, interrupted by the
//    next message that moves the shell (others, e.g. a page joining, are answered meanwhile:
//    view_message_leaves_shell_alone); then it builds solvers for new handle groups and hands a snapshot to
//  - the check thread, which measures validity (inverted tets, intersections) at low priority
//    on one core, off the interactive path.
// Every page shares the one session: a second tab shows the same shell and may drag it too.
//
// Security (docs/viewer.md): Host and Origin checks (view/request_guard.h), GET/HEAD of the
// embedded files only, message size and shape limits (parse_view_message), saves only into new
// plain-named folders of the output folder.
#include <gshell/view/view_session.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>

namespace gshell {

struct ViewServerOptions {
  std::string host = "127.0.0.1"; ///< address to bind (loopback only unless the user asks)
  int port = 8080;                ///< 0: any free port
  /// No drag for this long means the mouse rests: the settle starts (a release starts it at once).
  double rest_seconds = 0.1;
  int max_pages = 8;              ///< open pages at a time; more get a message and are closed
  /// Lines for the terminal (pages joining and leaving, refusals, what was saved); may be empty.
  std::function<void(const std::string&)> log;

  /// \throws InputError naming the parameter (port, rest_seconds, max_pages) when out of range.
  void check() const;
  /// check(), then resolves the host and listens on host:port once and lets go: the errors
  /// ViewServer's constructor gives for them (an unknown host, a port in use), before a long
  /// setup (a shell to generate). The port may still be taken meanwhile.
  void check_address() const;
};

class ViewServer {
public:
  /// Binds host:port (nothing is served until run()).
  /// \throws InputError when the page is missing from this build, the options are bad, or the
  ///         host is neither an address nor a known name, or the address cannot be bound (in use,
  ///         not an address of this machine).
  ViewServer(ViewSession session, ViewServerOptions options);
  /// Stops and joins every thread.
  ~ViewServer();
  ViewServer(const ViewServer&) = delete;
  ViewServer& operator=(const ViewServer&) = delete;

  int port() const;
  /// "http://HOST:PORT/" (brackets around an IPv6 address).
  std::string url() const;

  /// Serves until stop(); returns when the network has shut down.
  void run();
  /// Any thread, any time (also before run()): closes the pages ("going away"), stops accepting,
  /// interrupts a settle; run() returns soon after.
  void stop();
  /// After run() returned: waits up to `timeout` for the solver and check threads to finish what
  /// they are doing (a solver build or a validity check cannot be interrupted). True when they did.
  bool wait_finished(std::chrono::milliseconds timeout);

private:
  struct Impl;
  std::shared_ptr<Impl> impl_;
};

} // namespace gshell
