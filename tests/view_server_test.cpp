// The viewer's server (view/view_server.h) over real sockets: it serves the embedded page, refuses
// requests whose Host is not this server (DNS rebinding) and WebSockets from a foreign Origin,
// answers bad messages with an error, lets every page share the session, and `gshell view` stops
// cleanly within a second of SIGTERM.
#include "test_support.h"

#include <gshell/error.h>
#include <gshell/view/request_guard.h>
#include <gshell/view/view_input.h>
#include <gshell/view/view_server.h>

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <gtest/gtest.h>

#include <cstring>
#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <deque>
#include <functional>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

using namespace gshell;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;

extern char** environ;

namespace {

ViewInput plate() {
  ViewInputOptions o;
  o.generate.thickness.thickness = 0.1;
  return load_view_input({"builtin:plane:6"}, o);
}

/// A server on a free port of 127.0.0.1, running on its own thread.
struct RunningServer {
  std::unique_ptr<ViewServer> server;
  std::thread thread;
  explicit RunningServer(int max_pages = 8) {
    ViewServerOptions o;
    o.port = 0;
    o.max_pages = max_pages;
    server = std::make_unique<ViewServer>(ViewSession(plate()), o);
    thread = std::thread([this] { server->run(); });
  }
  ~RunningServer() {
    server->stop();
    thread.join();
  }
  std::string host() const { return "127.0.0.1:" + std::to_string(server->port()); }
};

http::response<http::string_body> request(int port, http::verb verb, const std::string& target,
                                          const std::optional<std::string>& host) {
  net::io_context ioc;
  beast::tcp_stream stream(ioc);
  stream.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)));
  http::request<http::string_body> req(verb, target, 11);
  if (host) req.set(http::field::host, *host);
  http::write(stream, req);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.skip(verb == http::verb::head); // a HEAD answer has no body, whatever its Content-Length
  http::read(stream, buffer, parser);
  return parser.release();
}

/// A WebSocket client; `origin` empty = no Origin header (not a browser).
struct Client {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  Client(int port, const std::string& host, const std::string& origin, const std::string& path = "/ws") {
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)));
    ws.set_option(websocket::stream_base::decorator([origin](websocket::request_type& req) {
      if (!origin.empty()) req.set(http::field::origin, origin);
    }));
    ws.handshake(host, path);
  }
  /// The next text message (binary frames skipped).
  json next_text() {
    for (;;) {
      beast::flat_buffer buffer;
      ws.read(buffer);
      if (ws.got_text()) return json::parse(beast::buffers_to_string(buffer.data()));
    }
  }
  /// The first text message of `type` that satisfies `pred`, in the order they came; messages
  /// passed over are kept for later calls (pages hear from two threads: the order of e.g. "pages"
  /// and "hello" is not fixed).
  json next(const std::string& type, const std::function<bool(const json&)>& pred = {}) {
    const auto wanted = [&](const json& j) { return j["type"] == type && (!pred || pred(j)); };
    for (auto it = backlog.begin(); it != backlog.end(); ++it)
      if (wanted(*it)) {
        json j = *it;
        backlog.erase(it);
        return j;
      }
    for (;;) {
      json j = next_text();
      if (wanted(j)) return j;
      backlog.push_back(j);
    }
  }
  std::deque<json> backlog;
  /// Positions frames received until a text message satisfies `pred` (other messages dropped).
  int positions_until(const std::function<bool(const json&)>& pred) {
    int count = 0;
    for (;;) {
      beast::flat_buffer buffer;
      ws.read(buffer);
      const std::string bytes = beast::buffers_to_string(buffer.data());
      if (ws.got_text()) {
        if (pred(json::parse(bytes))) return count;
      } else {
        std::uint32_t kind = 0;
        std::memcpy(&kind, bytes.data(), 4);
        if (kind == static_cast<std::uint32_t>(ViewFrameKind::Positions)) ++count;
      }
    }
  }
  void send(const std::string& text) {
    ws.text(true);
    ws.write(net::buffer(text));
  }
};

} // namespace

TEST(ViewServer, RequestGuardKnowsWhichHostsAreThisServer) {
  const RequestGuard g("127.0.0.1", 8080);
  for (const char* host : {"127.0.0.1:8080", "localhost:8080", "LOCALHOST:8080", "[::1]:8080"})
    EXPECT_TRUE(g.host_allowed(host)) << host;
  for (const char* host : {"", "evil.example:8080", "127.0.0.1", "127.0.0.1:8081", "localhost", "127.0.0.1:8080.evil",
                           "localhost.evil.example:8080", "127.0.0.2:8080"})
    EXPECT_FALSE(g.host_allowed(host)) << host;
  EXPECT_TRUE(g.origin_allowed("", false)); // no Origin: not a browser
  EXPECT_TRUE(g.origin_allowed("http://localhost:8080", true));
  for (const char* origin : {"", "null", "http://evil.example:8080", "https://localhost:8080", "http://localhost:8080/x",
                             "file://", "http://localhost:9090"})
    EXPECT_FALSE(g.origin_allowed(origin, true)) << origin;
  // A bound address of its own, an IPv6 one in brackets, and port 80 without the port.
  EXPECT_TRUE(RequestGuard("192.168.1.5", 8080).host_allowed("192.168.1.5:8080"));
  EXPECT_TRUE(RequestGuard("::1", 9000).host_allowed("[::1]:9000"));
  EXPECT_TRUE(RequestGuard("fe80::1", 9000).host_allowed("[fe80::1]:9000"));
  EXPECT_TRUE(RequestGuard("127.0.0.1", 80).host_allowed("localhost"));
  // Bound to every interface (--host 0.0.0.0 or ::), a request may name any of the machine's
  // addresses, which only IP literals can be sure to be: every one was refused as DNS rebinding.
  for (const char* wildcard : {"0.0.0.0", "::"}) {
    const RequestGuard any(wildcard, 8080);
    for (const char* host : {"192.0.2.2:8080", "[fd00::2]:8080", "10.1.2.3:8080", "localhost:8080"})
      EXPECT_TRUE(any.host_allowed(host)) << wildcard << " " << host;
    for (const char* host : {"evil.example:8080", "192.0.2.2:8081", "192.0.2.2", "192.0.2:8080", "[fd00::2:8080",
                             "fd00::2:8080", "192.0.2.2.evil:8080", ":8080"})
      EXPECT_FALSE(any.host_allowed(host)) << wildcard << " " << host;
    EXPECT_TRUE(any.origin_allowed("http://192.0.2.2:8080", true));
    EXPECT_FALSE(any.origin_allowed("http://evil.example:8080", true));
  }
  EXPECT_TRUE(RequestGuard("0.0.0.0", 80).host_allowed("192.0.2.2"));
  EXPECT_FALSE(RequestGuard("127.0.0.1", 8080).host_allowed("192.0.2.2:8080")); // only when bound to every interface
}

TEST(ViewServer, ServesThePageOnlyToRequestsNamingIt) {
  RunningServer s;
  const int port = s.server->port();
  EXPECT_EQ(s.server->url(), "http://127.0.0.1:" + std::to_string(port) + "/");
  const auto page = request(port, http::verb::get, "/", s.host());
  EXPECT_EQ(page.result(), http::status::ok);
  EXPECT_NE(page.body().find("gshell view"), std::string::npos);
  EXPECT_NE(std::string(page[http::field::content_type]).find("text/html"), std::string::npos);
  EXPECT_NE(std::string(page["Content-Security-Policy"]).find("script-src 'self'"), std::string::npos);
  const auto three = request(port, http::verb::get, "/three/three.module.js", "localhost:" + std::to_string(port));
  EXPECT_EQ(three.result(), http::status::ok);
  EXPECT_GT(three.body().size(), 100000u); // three.js itself, embedded: no CDN
  EXPECT_EQ(request(port, http::verb::head, "/main.js?v=1", s.host()).result(), http::status::ok);
  // DNS rebinding: a page of evil.example resolved to 127.0.0.1 sends Host: evil.example.
  for (const std::optional<std::string>& host : {std::optional<std::string>("evil.example:" + std::to_string(port)),
                                                 std::optional<std::string>("127.0.0.1"),
                                                 std::optional<std::string>(std::nullopt)})
    EXPECT_EQ(request(port, http::verb::get, "/", host).result(), http::status::forbidden) << host.value_or("(none)");
  // A refused Host is not copied into the answer's security policy (it was, whatever it said).
  const auto refused = request(port, http::verb::get, "/", std::string("evil.example; script-src *"));
  EXPECT_EQ(refused.result(), http::status::forbidden);
  EXPECT_EQ(std::string(refused["Content-Security-Policy"]).find("evil"), std::string::npos) << refused["Content-Security-Policy"];
  EXPECT_NE(std::string(page["Content-Security-Policy"]).find("connect-src 'self' ws://" + s.host()), std::string::npos);
  EXPECT_EQ(request(port, http::verb::get, "/../../etc/passwd", s.host()).result(), http::status::not_found);
  EXPECT_EQ(request(port, http::verb::get, "/nothing.js", s.host()).result(), http::status::not_found);
  EXPECT_EQ(request(port, http::verb::post, "/", s.host()).result(), http::status::method_not_allowed);
}

TEST(ViewServer, RefusesWebSocketsFromForeignOrigins) {
  RunningServer s;
  const int port = s.server->port();
  EXPECT_THROW(Client(port, s.host(), "http://evil.example"), beast::system_error);
  EXPECT_THROW(Client(port, s.host(), "http://localhost:" + std::to_string(port + 1)), beast::system_error);
  EXPECT_THROW(Client(port, "evil.example:" + std::to_string(port), ""), beast::system_error);
  EXPECT_THROW(Client(port, s.host(), "", "/nope"), beast::system_error); // the page's socket is at /ws only
  Client ok(port, s.host(), "http://127.0.0.1:" + std::to_string(port));
  const json hello = ok.next("hello");
  EXPECT_EQ(hello["vertices"], 49);
  Client tool(port, s.host(), ""); // not a browser: no Origin
  EXPECT_EQ(tool.next("hello")["vertices"], 49);
}

TEST(ViewServer, BadMessagesAreAnsweredAndPagesShareTheSession) {
  RunningServer s;
  const int port = s.server->port();
  Client a(port, s.host(), ""), b(port, s.host(), "");
  a.next("hello");
  b.next("hello");
  a.send("{\"type\":\"drag\",\"seq\":1,\"handle\":0,\"translate\":[NaN,0,0]}");
  EXPECT_NE(a.next("error")["message"].get<std::string>().find("JSON"), std::string::npos);
  a.send(R"({"type":"add_handle","vertices":[98]})");
  EXPECT_NE(a.next("error")["message"].get<std::string>().find("out of range"), std::string::npos);
  a.ws.binary(true);
  a.ws.write(net::buffer(std::string("\x01\x02\x03", 3)));
  EXPECT_NE(a.next("error")["message"].get<std::string>().find("binary"), std::string::npos);
  a.send(std::string(17u << 20, ' ')); // beyond the parser's 16 MiB: refused, the page stays
  EXPECT_NE(a.next("error")["message"].get<std::string>().find("too long"), std::string::npos);
  // Still working, and the other page sees what this one does.
  a.send(R"({"type":"add_handle","name":"corner","vertices":[0,1,49]})");
  const auto some = [](const json& j) { return !j["handles"]["handles"].empty(); };
  EXPECT_EQ(b.next("handles", some)["handles"]["handles"][0]["name"], "corner");
  EXPECT_EQ(a.next("handles", some)["handles"]["handles"][0]["vertices"].size(), 3u);
  // Both are told the session is shared.
  const auto two = [](const json& j) { return j["count"] == 2; };
  EXPECT_EQ(a.next("pages", two)["max"], 8);
  EXPECT_EQ(b.next("pages", two)["max"], 8);
}

TEST(ViewServer, PagesBeyondTheLimitGetAClearMessage) {
  RunningServer s(1);
  Client first(s.server->port(), s.host(), "");
  first.next("hello");
  Client second(s.server->port(), s.host(), "");
  const json refusal = second.next_text();
  EXPECT_EQ(refusal["type"], "error");
  EXPECT_NE(refusal["message"].get<std::string>().find("1 pages open"), std::string::npos);
  beast::flat_buffer buffer;
  EXPECT_THROW(second.ws.read(buffer), beast::system_error); // then closed
}

TEST(ViewServer, BindErrorsAreInputErrors) {
  ViewServerOptions o;
  o.port = 0;
  o.host = "no-such-host.invalid";
  EXPECT_THROW(ViewServer(ViewSession(plate()), o), InputError);
  o.host = "127.0.0.1";
  o.port = 70000;
  EXPECT_THROW(ViewServer(ViewSession(plate()), o), InputError);
  RunningServer s;
  o.port = s.server->port(); // taken
  EXPECT_THROW(ViewServer(ViewSession(plate()), o), InputError);
}

TEST(ViewServer, SigtermStopsGshellViewCleanly) {
  // The CLI on a free port, with a page connected.
  int out[2];
  ASSERT_EQ(pipe(out), 0);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, out[1], 1);
  posix_spawn_file_actions_addclose(&actions, out[0]);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  std::vector<std::string> args{GSHELL_CLI_PATH, "view", "builtin:plane:6", "--thickness", "0.1", "--port", "0"};
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, GSHELL_CLI_PATH, &actions, nullptr, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  close(out[1]);
  std::string line;
  char c;
  while (read(out[0], &c, 1) == 1 && c != '\n') line += c;
  close(out[0]);
  ASSERT_EQ(line.rfind("http://127.0.0.1:", 0), 0u) << line; // the first line on stdout is the URL
  const int port = std::stoi(line.substr(std::string("http://127.0.0.1:").size()));
  Client page(port, "127.0.0.1:" + std::to_string(port), "");
  page.next("hello");

  const auto start = std::chrono::steady_clock::now();
  ASSERT_EQ(kill(pid, SIGTERM), 0);
  // The page is told the server goes away.
  beast::flat_buffer buffer;
  beast::error_code ec;
  while (!ec) page.ws.read(buffer, ec);
  EXPECT_EQ(ec, websocket::error::closed);
  EXPECT_EQ(page.ws.reason().code, websocket::close_code::going_away);
  // It exits by itself, with status 0. How fast is not asserted (a sanitizer build beside a
  // compile took 1.9 s); the limit only keeps a hung server from hanging the suite.
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - start > std::chrono::seconds(60)) {
      kill(pid, SIGKILL);
      waitpid(pid, &status, 0);
      FAIL() << "gshell view still running 60 s after SIGTERM";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << status;
}

TEST(ViewServer, APageThatSaysWhatItDrewGetsOnePositionsFrameAtATime) {
  // Flow control: after a page's first "drawn", the server sends it the next positions frame only
  // once it has drawn the last one, the newest waiting in between (a slow page gets the latest
  // shell, not a backlog), and every later message waits behind that frame (no status reaches the
  // page before the shell it describes). Pages that never say so get every frame at once.
  RunningServer s;
  Client page(s.server->port(), s.host(), ""), tool(s.server->port(), s.host(), "");
  page.next("stats"); // the end of the welcome
  tool.next("stats");
  page.send(R"({"type":"drawn"})");
  page.send(R"({"type":"add_handle","name":"all","vertices":[0,1,2,3,4,5,6,49,50,51]})");
  page.next("handles", [](const json& j) { return !j["handles"]["handles"].empty(); });
  for (int k = 1; k <= 6; ++k)
    page.send(R"({"type":"drag","seq":)" + std::to_string(k) + R"(,"handle":0,"translate":[)" + std::to_string(0.05 * k) + ",0,0]}");
  page.send(R"({"type":"release"})");
  // The shell settled after the last drag (a settle may also come between the handle and the drags).
  const auto settled = [](const json& j) {
    return j["type"] == "stats" && j["phase"] == "settled" && j["step"].is_object() && j["step"]["seq"] == 6;
  };
  // The tool page gets the answers and the settled shell; by the time it has the status, the
  // network thread has routed the same messages to the page, which holds them back.
  EXPECT_GE(tool.positions_until(settled), 2);
  page.send(R"({"type":"drawn"})");
  // Its first answer (on its way before the page drew), then, once it has drawn, the newest waiting
  // frame (the settled shell), then the status.
  EXPECT_EQ(page.positions_until(settled), 2);
  // Nothing else was waiting: the answer to a later message comes without another frame.
  page.send(R"({"type":"drawn"})");
  page.send(R"({"type":"save_handles"})"); // answered to this page only
  EXPECT_EQ(page.positions_until([](const json& j) { return j["type"] == "handles_file"; }), 0);
}

TEST(ViewServer, APageHearsNothingOfTheSessionBeforeItsWelcome) {
  // Pages join while another page keeps the solver busy with drags: whatever the session broadcasts
  // meanwhile is in the newcomer's welcome, so before "hello" it may hear only the page count (a
  // values frame or status ahead of it would reach a page that has no shell yet).
  RunningServer s;
  Client tool(s.server->port(), s.host(), "");
  tool.next("stats");
  tool.send(R"({"type":"add_handle","name":"all","vertices":[0,1,2,3,4,5,6,49,50,51]})");
  tool.next("handles", [](const json& j) { return !j["handles"]["handles"].empty(); });
  for (int k = 1; k <= 30; ++k) {
    for (int d = 0; d < 3; ++d)
      tool.send(R"({"type":"drag","seq":)" + std::to_string(3 * k + d) + R"(,"handle":0,"translate":[)" +
                std::to_string(0.01 * (3 * k + d)) + ",0,0]}");
    Client page(s.server->port(), s.host(), "");
    std::vector<std::string> before_hello;
    for (;;) {
      beast::flat_buffer buffer;
      page.ws.read(buffer);
      if (!page.ws.got_text()) {
        before_hello.push_back("a binary frame");
        continue;
      }
      const json j = json::parse(beast::buffers_to_string(buffer.data()));
      if (j["type"] == "hello") break;
      if (j["type"] != "pages") before_hello.push_back(j["type"]);
    }
    EXPECT_TRUE(before_hello.empty()) << "page " << k << " first heard: " << before_hello.front();
    page.ws.close(websocket::close_code::normal);
  }
}

TEST(ViewServer, PagesJoiningOrAskingDuringASettleDoNotRestartIt) {
  // A settle stops for the next message that moves the shell; a page joining, a handle file or a
  // save asked for are answered while it runs (an interrupted guarded settle goes back to its last
  // valid state: pages that kept asking kept the shell from ever settling).
  ViewInputOptions o;
  o.generate.thickness.thickness = 0.05;
  const int res = 30, n = res + 1, base = n * n;
  test::TempDir out;
  ViewSessionOptions session_options;
  session_options.output_dir = out.path().string();
  ViewServerOptions so;
  so.port = 0;
  ViewServer server(ViewSession(load_view_input({"builtin:plane:" + std::to_string(res)}, o), session_options), so);
  std::thread thread([&] { server.run(); });
  const std::string host = "127.0.0.1:" + std::to_string(server.port());
  {
    Client tool(server.port(), host, "");
    tool.next("stats");
    // Two opposite edges: one held, the other lifted and turned, so the shell bends.
    const auto edge = [&](int j) {
      std::string ids;
      for (int i = 0; i < n; ++i)
        for (const int layer : {0, base}) ids += (ids.empty() ? "" : ",") + std::to_string(layer + j * n + i);
      return ids;
    };
    tool.send(R"({"type":"add_handle","name":"held","vertices":[)" + edge(0) + "]}");
    tool.send(R"({"type":"add_handle","name":"pulled","vertices":[)" + edge(res) + "]}");
    tool.next("handles", [](const json& j) { return j["handles"]["handles"].size() == 2; });
    tool.send(R"({"type":"grab","handle":1})");
    tool.send(R"({"type":"drag","seq":1,"handle":1,"translate":[0,-0.8,0.9],"axis":[1,0,0],"degrees":120})");
    // From its answer on, only the release and the pages below reach the solver.
    tool.next("stats", [](const json& j) { return j["step"].is_object() && j["step"]["seq"] == 1; });
    tool.send(R"({"type":"release"})");
    // Pages come and ask until the shell has settled; none of them may find the settle interrupted,
    // and a save is refused until it has settled.
    int joined_while_settling = 0;
    for (int k = 0;; ++k) {
      Client page(server.port(), host, "");
      const json stats = page.next("stats");
      EXPECT_NE(stats["phase"], "interrupted") << stats.dump();
      if (stats["phase"] == "settling") ++joined_while_settling;
      page.send(R"({"type":"save_handles"})");
      EXPECT_EQ(page.next("handles_file")["handles"]["handles"].size(), 2u);
      page.send(R"({"type":"save_shell","folder":"pose)" + std::to_string(k) + "\"}");
      json answer;
      do answer = page.next_text();
      while (answer["type"] != "error" && answer["type"] != "saved");
      if (answer["type"] == "saved" || stats["phase"] == "interrupted") break;
      EXPECT_NE(answer["message"].get<std::string>().find("still moving"), std::string::npos) << answer.dump();
      page.ws.close(websocket::close_code::normal);
    }
    std::printf("pages joined while the shell settled: %d\n", joined_while_settling);
  }
  server.stop();
  thread.join();
}
