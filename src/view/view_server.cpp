#include <gshell/view/view_server.h>

#include <gshell/error.h>
#include <gshell/view/request_guard.h>

#include "view/web_assets.h"

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <nlohmann/json.hpp>
#include <tbb/task_arena.h>

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

namespace gshell {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

namespace {

/// HTTP requests are small (GET of a file): anything bigger is not from our page.
constexpr std::size_t kHttpHeaderLimit = 16 * 1024;
constexpr std::size_t kHttpBodyLimit = 16 * 1024;
/// A "drawn" message is tiny: longer text is never one (no second parse of big messages).
constexpr std::size_t kDrawnMessageBytes = 64;
/// After stop(), pages get this long to receive their "going away" before the loop ends.
constexpr auto kCloseGrace = std::chrono::milliseconds(300);

/// One message on its way to a page.
struct Outgoing {
  std::shared_ptr<const std::string> bytes;
  bool binary = false;
  std::uint32_t frame_kind = 0; ///< binary frames: ViewFrameKind (a newer one replaces a waiting one)
  bool snapshot = false;        ///< ViewOutgoing::snapshot

  /// A newer message of the same kind makes a waiting one obsolete (frames of one kind, stats).
  bool replaces(const Outgoing& waiting) const {
    return (frame_kind != 0 && frame_kind == waiting.frame_kind) || (snapshot && waiting.snapshot);
  }
};

std::uint32_t frame_kind_of(const std::string& bytes) {
  std::uint32_t kind = 0;
  if (bytes.size() >= kViewFrameHeaderBytes) std::memcpy(&kind, bytes.data(), 4);
  return kind;
}

/// What the solver thread is given to do, in order.
struct Item {
  enum Kind { Welcome, Message, Certified, PageLeft } kind = Message;
  int page = 0;
  std::string bytes;
  Clock::time_point received{};
  std::uint64_t version = 0;
  nlohmann::ordered_json validity;
};

} // namespace

void ViewServerOptions::check() const {
  if (port < 0 || port > 65535) throw InputError("port must be in 0..65535 (0: any free port)");
  if (!(rest_seconds >= 0) || !std::isfinite(rest_seconds)) throw InputError("rest_seconds must be >= 0");
  if (max_pages < 1) throw InputError("max_pages must be >= 1");
}

namespace {

/// Opens `acceptor` listening on options.host:port (a host name resolved to an address of this
/// machine). \throws InputError as ViewServer's constructor.
void listen_on(tcp::acceptor& acceptor, const ViewServerOptions& options) {
  beast::error_code ec;
  const net::ip::address address = net::ip::make_address(options.host, ec);
  tcp::endpoint endpoint;
  if (ec) { // a host name: resolve it to an address of this machine
    tcp::resolver resolver(acceptor.get_executor());
    const auto results = resolver.resolve(options.host, std::to_string(options.port), ec);
    if (ec || results.empty()) throw InputError("host " + options.host + ": not an address or a known host name");
    endpoint = *results.begin();
  } else {
    endpoint = tcp::endpoint(address, static_cast<unsigned short>(options.port));
  }
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw InputError("cannot listen on " + options.host + ":" + std::to_string(options.port) + ": " + ec.message());
}

} // namespace

void ViewServerOptions::check_address() const {
  check();
  net::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  listen_on(acceptor, *this); // and let go: the server binds it again
}

class Page;

// Everything the server's threads share (ViewServer::Impl is this).
struct ServerCore {
  ViewSession session;
  ViewServerOptions options;
  std::optional<RequestGuard> guard;
  net::io_context ioc{1};
  tcp::acceptor acceptor{ioc};
  net::steady_timer stop_timer{ioc};
  net::steady_timer accept_retry{ioc}; ///< the pause after a failed accept
  int port = 0;
  std::string url;

  // Network thread only.
  std::map<int, std::shared_ptr<Page>> pages;
  int next_page = 1;
  bool network_stopping = false;

  // The solver thread's inbox.
  std::mutex mutex;
  std::condition_variable wake;
  std::deque<Item> inbox;
  std::atomic<bool> inbox_nonempty{false};
  std::atomic<bool> stopping{false};

  // The check thread's task.
  std::mutex check_mutex;
  std::condition_variable check_wake;
  std::optional<ViewSession::CertifyTask> check_task;
  std::atomic<bool> check_busy{false};

  std::thread solver_thread, check_thread;
  std::mutex finished_mutex;
  std::condition_variable finished_cv;
  int threads_running = 0;

  std::mutex log_mutex;

  ServerCore(ViewSession s, ViewServerOptions o) : session(std::move(s)), options(std::move(o)) {}

  void log(const std::string& line) {
    if (!options.log) return;
    std::lock_guard lock(log_mutex);
    options.log(line);
  }

  // ---- network thread ----------------------------------------------------------------------
  void accept();
  void page_opened(const std::shared_ptr<Page>& page);
  void page_closed(int id);
  void broadcast_pages();
  /// A message of the shared session (the solver thread's) on to its page(s): a page hears the
  /// broadcasts only after its own welcome has started.
  void route(int target, const Outgoing& out);

  /// Any thread: hands a message to the network thread for one page (target > 0) or all (0).
  void deliver(int target, ViewOutgoing message) {
    Outgoing out;
    out.binary = message.binary;
    out.frame_kind = message.binary ? frame_kind_of(message.bytes) : 0;
    out.snapshot = message.snapshot;
    out.bytes = std::make_shared<const std::string>(std::move(message.bytes));
    net::post(ioc, [this, target, out] { route(target, out); });
  }

  ViewSink sink(int sender) {
    return [this, sender](ViewOutgoing m) {
      const int target = m.to_sender ? sender : 0;
      deliver(target, std::move(m));
    };
  }

  // ---- solver thread -----------------------------------------------------------------------
  void post(Item item) {
    {
      std::lock_guard lock(mutex);
      inbox.push_back(std::move(item));
      inbox_nonempty = true;
    }
    wake.notify_one();
  }

  void solver_loop();
  void skip_superseded_frame_requests(std::deque<Item>& items) const;
  void process(Item& item);
  /// Whether the settle may answer `item` and go on (view_message_leaves_shell_alone; welcomes and
  /// check results too).
  bool leaves_shell_alone(const Item& item) const;
  void check_loop();

  void thread_finished() {
    {
      std::lock_guard lock(finished_mutex);
      --threads_running;
    }
    finished_cv.notify_all();
  }

  void request_stop() {
    // Set under both mutexes: a thread between testing its wait's predicate and blocking would
    // otherwise miss the notification and sleep on (a server that never stops).
    {
      std::scoped_lock lock(mutex, check_mutex);
      stopping = true;
    }
    wake.notify_all();
    check_wake.notify_all();
  }
};

struct ViewServer::Impl : ServerCore {
  using ServerCore::ServerCore;
};

// ---- a page's WebSocket ------------------------------------------------------------------------

class Page : public std::enable_shared_from_this<Page> {
public:
  Page(beast::tcp_stream stream, ServerCore& server, int id) : ws_(std::move(stream)), server_(server), id_(id) {}

  int id() const { return id_; }
  bool welcomed = false; ///< has had the start of its welcome (ServerCore::route)

  void start(http::request<http::string_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "gshell view"); }));
    // Twice the parser's limit: a message a little too long gets the parser's clear error on the
    // page; only a far bigger one makes Beast close the connection (1009, shown by the page).
    ws_.read_message_max(2 * server_.session.limits().max_bytes);
    // A page that goes (a reload, a closed tab) sends a close frame: it leaves the count at once,
    // not when the close handshake has finished behind a frame still being written to it, so a
    // reloaded page is not told that another page shares the session.
    ws_.control_callback([weak = weak_from_this()](websocket::frame_type kind, beast::string_view) {
      if (kind != websocket::frame_type::close) return;
      if (const auto self = weak.lock()) {
        self->open_ = false;
        self->server_.page_closed(self->id_);
      }
    });
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return;
      self->open_ = true;
      self->server_.page_opened(self);
    });
  }

  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) {
        self->open_ = false;
        self->server_.page_closed(self->id_);
        return;
      }
      if (!self->ws_.got_text()) {
        self->send_text(R"({"type":"error","request":null,"message":"binary messages are not accepted: send JSON text"})");
      } else if (self->buffer_.size() <= kDrawnMessageBytes &&
                 beast::buffers_to_string(self->buffer_.data()).find("\"drawn\"") != std::string::npos &&
                 self->is_drawn(beast::buffers_to_string(self->buffer_.data()))) {
        self->drawn();
      } else {
        Item item;
        item.kind = Item::Message;
        item.page = self->id_;
        item.bytes = beast::buffers_to_string(self->buffer_.data());
        item.received = Clock::now();
        self->server_.post(std::move(item));
      }
      self->buffer_.consume(self->buffer_.size());
      self->read();
    });
  }

  void send(const Outgoing& out) {
    if (!open_ || close_code_) return;
    // Flow control (pages that say what they have drawn): one positions frame on its way at a
    // time. While a newer one waits for the page to draw, every later message waits behind it, in
    // order, so that no status (e.g. "settled") reaches the page before the shell it describes.
    const bool positions = out.frame_kind == static_cast<std::uint32_t>(ViewFrameKind::Positions);
    if (!held_.empty() || (positions && acknowledges_ && undrawn_)) {
      // A newer frame takes a waiting one's place (still before the messages sent after it); a
      // newer stats snapshot goes last (after what it follows) and drops the waiting one.
      const auto older = std::find_if(held_.begin(), held_.end(), [&](const Outgoing& w) { return out.replaces(w); });
      if (older != held_.end() && !out.snapshot) {
        *older = out;
        return;
      }
      if (older != held_.end()) held_.erase(older);
      held_.push_back(out);
      return;
    }
    if (positions && acknowledges_) undrawn_ = true;
    // A positions or values frame not yet on its way is out of date once a newer one comes.
    if (out.frame_kind == static_cast<std::uint32_t>(ViewFrameKind::Positions) ||
        out.frame_kind == static_cast<std::uint32_t>(ViewFrameKind::Values)) {
      for (std::size_t i = writing_ ? 1 : 0; i < queue_.size(); ++i)
        if (queue_[i].frame_kind == out.frame_kind) {
          queue_[i] = out;
          return;
        }
    }
    queue_.push_back(out);
    if (!writing_) write_next();
  }

  void send_text(const std::string& text) {
    Outgoing out;
    out.bytes = std::make_shared<const std::string>(text);
    send(out);
  }

  /// The page has drawn the last positions frame it got: what waited goes, in order (its first
  /// positions frame makes the rest wait again only if a newer frame comes before the next "drawn").
  void drawn() {
    acknowledges_ = true;
    undrawn_ = false;
    std::deque<Outgoing> waiting;
    waiting.swap(held_);
    for (const Outgoing& out : waiting) send(out);
  }

  bool is_drawn(const std::string& text) const { return is_view_message<ViewDrawn>(text, server_.session.limits()); }

  /// Closes after what is queued has gone out.
  void close(websocket::close_code code) {
    if (!open_ || close_code_) return;
    close_code_ = code;
    if (!writing_) do_close();
  }

private:
  void write_next() {
    writing_ = true;
    ws_.binary(queue_.front().binary);
    ws_.async_write(net::buffer(*queue_.front().bytes), [self = shared_from_this()](beast::error_code ec, std::size_t) {
      self->writing_ = false;
      self->queue_.pop_front();
      if (ec) {
        self->queue_.clear();
        return;
      }
      if (self->close_code_) self->do_close();
      else if (!self->queue_.empty()) self->write_next();
    });
  }

  void do_close() {
    queue_.clear();
    ws_.async_close(*close_code_, [self = shared_from_this()](beast::error_code) {});
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  ServerCore& server_;
  int id_;
  bool open_ = false, writing_ = false;
  bool acknowledges_ = false, undrawn_ = false; ///< flow control (drawn())
  std::deque<Outgoing> held_; ///< flow control: what waits for the page's next "drawn", in order
  std::optional<websocket::close_code> close_code_;
  std::deque<Outgoing> queue_;
};

// ---- plain HTTP: the page's files ------------------------------------------------------------

class HttpConnection : public std::enable_shared_from_this<HttpConnection> {
public:
  HttpConnection(tcp::socket socket, ServerCore& server) : stream_(std::move(socket)), server_(server) {}

  void read() {
    parser_.emplace();
    parser_->header_limit(kHttpHeaderLimit);
    parser_->body_limit(kHttpBodyLimit);
    stream_.expires_after(std::chrono::seconds(30));
    http::async_read(stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return self->shut();
      self->handle(self->parser_->release());
    });
  }

private:
  void handle(http::request<http::string_body> req) {
    const std::string host(req[http::field::host]);
    if (!server_.guard->host_allowed(host)) {
      server_.log("refused a request for Host \"" + host.substr(0, 100) + "\" (not this server: DNS rebinding?)");
      return respond(req, http::status::forbidden,
                     "gshell view: refused: the Host header does not name this server\n", "text/plain; charset=utf-8",
                     false);
    }
    std::string path(req.target());
    path = path.substr(0, path.find_first_of("?#"));
    if (websocket::is_upgrade(req)) {
      if (path != "/ws") // the page's socket; anywhere else an upgrade is no request of ours
        return respond(req, http::status::not_found, "gshell view: WebSocket only at /ws\n", "text/plain; charset=utf-8",
                       false);
      const auto origin = req.find(http::field::origin);
      const bool present = origin != req.end();
      if (!server_.guard->origin_allowed(present ? std::string_view(origin->value().data(), origin->value().size()) : "",
                                         present)) {
        server_.log("refused a WebSocket from Origin \"" + std::string(origin->value()).substr(0, 100) + "\"");
        return respond(req, http::status::forbidden, "gshell view: refused: WebSocket from a foreign Origin\n",
                       "text/plain; charset=utf-8", false);
      }
      stream_.expires_never(); // the WebSocket keeps its own timeouts
      const int id = server_.next_page++;
      std::make_shared<Page>(std::move(stream_), server_, id)->start(std::move(req));
      return;
    }
    if (req.method() != http::verb::get && req.method() != http::verb::head)
      return respond(req, http::status::method_not_allowed, "gshell view: only GET and HEAD\n",
                     "text/plain; charset=utf-8", req.keep_alive());
    if (path == "/") path = "/index.html";
    for (const WebAsset& asset : web_assets())
      if (asset.path == path)
        return respond(req, http::status::ok, std::string(asset.bytes), std::string(asset.content_type), req.keep_alive());
    respond(req, http::status::not_found, "gshell view: no such file\n", "text/plain; charset=utf-8", req.keep_alive());
  }

  void respond(const http::request<http::string_body>& req, http::status status, std::string body,
               const std::string& type, bool keep_alive) {
    auto res = std::make_shared<http::response<http::string_body>>(status, req.version());
    res->set(http::field::server, "gshell view");
    res->set(http::field::content_type, type);
    res->set(http::field::cache_control, "no-cache");
    res->set("X-Content-Type-Options", "nosniff");
    res->set("X-Frame-Options", "DENY");
    res->set("Referrer-Policy", "no-referrer");
    // Only our own files, no inline script, sockets only back to this server. The Host goes into the
    // policy only once checked: a refused request's Host ("evil; script-src *") was copied in.
    const std::string host(req[http::field::host]);
    // (CSP sources cannot name an IPv6 address, "[::1]:port": 'self' covers the socket there.)
    const std::string sockets =
        server_.guard->host_allowed(host) && host.rfind('[', 0) != 0 ? " ws://" + host : std::string();
    res->set("Content-Security-Policy", "default-src 'self'; script-src 'self'; style-src 'self'; img-src 'self' data: "
                                        "blob:; connect-src 'self'" + sockets +
                                            "; base-uri 'none'; form-action 'none'; frame-ancestors 'none'");
    res->keep_alive(keep_alive);
    const bool head = req.method() == http::verb::head;
    res->body() = std::move(body);
    res->prepare_payload();
    if (head) res->body().clear(); // Content-Length stays that of the GET
    http::async_write(stream_, *res, [self = shared_from_this(), res, keep_alive](beast::error_code ec, std::size_t) {
      if (ec || !keep_alive) return self->shut();
      self->read();
    });
  }

  void shut() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  ServerCore& server_;
};

// ---- network thread ----------------------------------------------------------------------------

void ServerCore::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (network_stopping) return;
    if (!ec) {
      std::make_shared<HttpConnection>(std::move(socket), *this)->read();
      return accept();
    }
    // Out of file descriptors (EMFILE) the connection stays queued and an immediate retry fails at
    // once again: the loop spun at 100 % CPU until clients left. A pause lets connections close.
    accept_retry.expires_after(std::chrono::milliseconds(100));
    accept_retry.async_wait([this](beast::error_code wait_error) {
      if (!wait_error && !network_stopping) accept();
    });
  });
}

void ServerCore::page_opened(const std::shared_ptr<Page>& page) {
  if (network_stopping) return page->close(websocket::close_code::going_away);
  if (static_cast<int>(pages.size()) >= options.max_pages) {
    page->send_text(R"({"type":"error","request":null,"message":"this viewer already has )" +
                    std::to_string(options.max_pages) + R"( pages open: close one and reload"})");
    page->close(websocket::close_code::try_again_later);
    log("refused a page: " + std::to_string(options.max_pages) + " pages are open");
    return;
  }
  pages[page->id()] = page;
  log("page " + std::to_string(page->id()) + " connected (" + std::to_string(pages.size()) + " open)");
  Item item;
  item.kind = Item::Welcome;
  item.page = page->id();
  post(std::move(item));
  page->read();
  broadcast_pages();
}

void ServerCore::page_closed(int id) {
  if (pages.erase(id) == 0) return;
  if (network_stopping && pages.empty()) return ioc.stop();
  log("page " + std::to_string(id) + " left (" + std::to_string(pages.size()) + " open)");
  broadcast_pages();
  Item item;
  item.kind = Item::PageLeft;
  item.page = id;
  post(std::move(item));
}

void ServerCore::broadcast_pages() {
  // Every page shares the one session: tell each how many others are looking.
  Outgoing out;
  out.bytes = std::make_shared<const std::string>(
      nlohmann::json{{"type", "pages"}, {"count", pages.size()}, {"max", options.max_pages}}.dump());
  for (auto& [id, page] : pages) page->send(out); // welcomed or not: the count is no session state
}

void ServerCore::route(int target, const Outgoing& out) {
  // A page joins the session's broadcasts with the first message addressed to it, its welcome's
  // "hello": what was broadcast before is already in the welcome, and a values frame or status
  // ahead of "hello" would reach a page that has no shell yet.
  if (target == 0) {
    for (auto& [id, page] : pages)
      if (page->welcomed) page->send(out);
  } else if (const auto it = pages.find(target); it != pages.end()) {
    it->second->welcomed = true;
    it->second->send(out);
  }
}

// ---- solver thread -------------------------------------------------------------------------------

bool ServerCore::leaves_shell_alone(const Item& item) const {
  return item.kind != Item::Message || view_message_leaves_shell_alone(item.bytes, session.limits());
}

void ServerCore::process(Item& item) {
  switch (item.kind) {
  case Item::Welcome: session.welcome(sink(item.page)); break;
  case Item::Message: session.receive(item.bytes, sink(item.page), item.received); break;
  case Item::PageLeft: session.page_left(sink(0)); break;
  case Item::Certified: // the check thread is free again once its result is in
    check_busy = false;
    session.certified(item.version, std::move(item.validity), sink(0));
    break;
  }
}

// Frame requests that the next message of the batch replaces (view_messages_to_act_on) are dropped.
void ServerCore::skip_superseded_frame_requests(std::deque<Item>& items) const {
  std::vector<std::string_view> messages;
  for (const Item& item : items)
    if (item.kind == Item::Message) messages.push_back(item.bytes);
  if (messages.size() < 2) return;
  const std::vector<bool> act = view_messages_to_act_on(messages, session.limits());
  std::deque<Item> kept;
  std::size_t message = 0;
  for (Item& item : items)
    if (item.kind != Item::Message || act[message++]) kept.push_back(std::move(item));
  items.swap(kept);
}

void ServerCore::solver_loop() {
  const ViewSink everyone = sink(0);
  const auto rest = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(options.rest_seconds));
  Clock::time_point last_drag = Clock::now() - rest;
  std::string last_logged;
  auto report = [&](const char* request, const std::string& message) {
    // Also on the terminal, once in a row (a drag and its settle fail alike): a solve started
    // before any page connected (--handles) has no one else to tell (a handle file that pose
    // refuses was silently not applied).
    if (message != last_logged) {
      const std::string prefix = "gshell view: "; // the log adds its own
      log(message.rfind(prefix, 0) == 0 ? message.substr(prefix.size()) : message);
      last_logged = message;
    }
    everyone({nlohmann::json{{"type", "error"}, {"request", request}, {"message", message}}.dump(
                  -1, ' ', false, nlohmann::json::error_handler_t::replace),
              false, false});
  };
  // A settle stops for the next item that moves the shell; items ahead of it that leave the shell
  // alone (a page joining, a check's result, a handle file asked for) are answered meanwhile.
  const auto interrupt = [&] {
    while (!stopping && inbox_nonempty) {
      std::deque<Item> items;
      {
        std::lock_guard lock(mutex);
        items.swap(inbox);
        inbox_nonempty = false;
      }
      for (; !items.empty() && leaves_shell_alone(items.front()); items.pop_front()) {
        try {
          process(items.front());
        } catch (const std::exception& e) {
          report(nullptr, std::string("internal error: ") + e.what());
        }
      }
      if (items.empty()) continue; // more may have come meanwhile
      std::lock_guard lock(mutex);
      inbox.insert(inbox.begin(), std::make_move_iterator(items.begin()), std::make_move_iterator(items.end()));
      inbox_nonempty = true;
      return true;
    }
    return stopping.load();
  };
  while (!stopping) {
    std::deque<Item> items;
    {
      std::lock_guard lock(mutex);
      items.swap(inbox);
      inbox_nonempty = false;
    }
    try {
      skip_superseded_frame_requests(items);
      for (Item& item : items) process(item);
      if (stopping) break;
      if (!items.empty()) continue; // more may have come meanwhile: the latest drag target wins
      if (session.drag_pending()) {
        last_drag = Clock::now();
        session.solve_drag(everyone);
        continue;
      }
      std::optional<Clock::time_point> deadline;
      if (session.settle_pending()) {
        if (session.settle_requested() || Clock::now() - last_drag >= rest) {
          session.settle(everyone, interrupt);
          continue;
        }
        deadline = last_drag + rest;
      } else if (session.prepare()) {
        continue;
      } else if (!check_busy) {
        if (std::optional<ViewSession::CertifyTask> task = session.certify_task()) {
          {
            std::lock_guard lock(check_mutex);
            check_task = std::move(task);
            check_busy = true;
          }
          check_wake.notify_one();
        }
      }
      std::unique_lock lock(mutex);
      const auto ready = [this] { return !inbox.empty() || stopping; };
      if (deadline) wake.wait_until(lock, *deadline, ready);
      else wake.wait(lock, ready);
    } catch (const InputError& e) { // e.g. handles that leave a part of the shell free
      report("drag", e.what());
    } catch (const std::exception& e) { // a bug: say so and keep serving
      report(nullptr, std::string("internal error: ") + e.what());
    }
  }
  thread_finished();
}

void ServerCore::check_loop() {
  // Off the interactive path: lowest priority, one core, so drags keep both.
  setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), 19);
  tbb::task_arena arena(1);
  while (true) {
    ViewSession::CertifyTask task;
    {
      std::unique_lock lock(check_mutex);
      check_wake.wait(lock, [this] { return check_task.has_value() || stopping; });
      if (stopping) break;
      task = std::move(*check_task);
      check_task.reset();
    }
    Item item;
    item.kind = Item::Certified;
    item.version = task.version;
    try {
      arena.execute([&] { item.validity = ViewSession::run_certify_task(task); });
    } catch (const std::exception& e) { // e.g. a shell with non-finite positions
      item.validity = {{"error", e.what()}, {"valid", false}};
    }
    post(std::move(item));
  }
  thread_finished();
}

// ---- ViewServer ----------------------------------------------------------------------------------

ViewServer::ViewServer(ViewSession session, ViewServerOptions options)
    : impl_(std::make_shared<Impl>(std::move(session), std::move(options))) {
  Impl& s = *impl_;
  s.options.check();
  if (web_assets().empty())
    throw InputError("view: this gshell was built without the viewer page (three.js was missing: run scripts/setup, "
                     "then rebuild)");
  listen_on(s.acceptor, s.options);
  s.port = s.acceptor.local_endpoint().port();
  const std::string shown = s.options.host.find(':') != std::string::npos ? "[" + s.options.host + "]" : s.options.host;
  s.url = "http://" + shown + ":" + std::to_string(s.port) + "/";
  s.guard.emplace(s.options.host, s.port);
  s.session.set_log([impl = impl_.get()](const std::string& line) { impl->log(line); });
}

ViewServer::~ViewServer() {
  stop();
  Impl& s = *impl_;
  if (s.solver_thread.joinable()) s.solver_thread.join();
  if (s.check_thread.joinable()) s.check_thread.join();
}

int ViewServer::port() const { return impl_->port; }
std::string ViewServer::url() const { return impl_->url; }

void ViewServer::run() {
  Impl& s = *impl_;
  if (s.stopping) return;
  {
    std::lock_guard lock(s.finished_mutex);
    s.threads_running = 2;
  }
  s.solver_thread = std::thread([&s] { s.solver_loop(); });
  s.check_thread = std::thread([&s] { s.check_loop(); });
  s.accept();
  s.ioc.run();
  s.request_stop(); // the loop ended for any reason: the other threads end too
}

void ViewServer::stop() {
  Impl& s = *impl_;
  s.request_stop();
  net::post(s.ioc, [&s] {
    if (s.network_stopping) return;
    s.network_stopping = true;
    beast::error_code ec;
    s.acceptor.close(ec);
    s.accept_retry.cancel();
    if (s.pages.empty()) return s.ioc.stop();
    for (auto& [id, page] : s.pages) page->close(websocket::close_code::going_away);
    s.stop_timer.expires_after(kCloseGrace); // or sooner, when the last page has gone (page_closed)
    s.stop_timer.async_wait([&s](beast::error_code) { s.ioc.stop(); });
  });
}

bool ViewServer::wait_finished(std::chrono::milliseconds timeout) {
  Impl& s = *impl_;
  std::unique_lock lock(s.finished_mutex);
  return s.finished_cv.wait_for(lock, timeout, [&s] { return s.threads_running == 0; });
}

} // namespace gshell
