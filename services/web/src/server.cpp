#include "motion/web/server.hpp"

#include <atomic>
#include <cctype>
#include <chrono>
#include <deque>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <spdlog/spdlog.h>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace motion::web {
namespace {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

constexpr auto kHttpTimeout = std::chrono::seconds(30);

std::string_view mime_type(const std::filesystem::path& path) {
  const std::string ext = path.extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".css") return "text/css; charset=utf-8";
  if (ext == ".json") return "application/json";
  if (ext == ".png") return "image/png";
  if (ext == ".svg") return "image/svg+xml";
  if (ext == ".ico") return "image/x-icon";
  return "application/octet-stream";
}

// The file a request target names under `root`, or nullopt for a target that is not a plain
// relative path of visible names (no "..", no hidden files, no query strings taken as names).
std::optional<std::filesystem::path> file_for(const std::filesystem::path& root, std::string_view target) {
  if (const auto query = target.find('?'); query != std::string_view::npos) target = target.substr(0, query);
  if (target.empty() || target.front() != '/') return std::nullopt;
  std::string relative(target.substr(1));
  if (relative.empty() || relative.back() == '/') relative += "index.html";
  std::filesystem::path path;
  std::stringstream parts(relative);
  for (std::string part; std::getline(parts, part, '/');) {
    if (part.empty() || part.front() == '.') return std::nullopt;
    for (const char c : part) {
      const bool plain = std::isalnum(static_cast<unsigned char>(c)) != 0 || c == '-' || c == '_' || c == '.';
      if (!plain) return std::nullopt;
    }
    path /= part;
  }
  return root / path;
}

std::string endpoint_text(const ListenAddress& listen) {
  const bool v6 = listen.address.find(':') != std::string::npos;
  return (v6 ? "[" + listen.address + "]" : listen.address) + ":" + std::to_string(listen.port);
}

std::string error_words(const beast::error_code& ec) {
  if (ec == asio::error::address_in_use) return "address in use";
  if (ec == asio::error::access_denied) return "permission denied";
  if (ec == boost::system::errc::address_not_available) return "no such local address";
  return ec.message();
}

}  // namespace

std::optional<ListenAddress> parse_listen(std::string_view text) {
  const auto colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size()) return std::nullopt;
  std::string_view host = text.substr(0, colon);
  const std::string_view port_text = text.substr(colon + 1);
  if (host.front() == '[') {
    if (host.size() < 3 || host.back() != ']') return std::nullopt;
    host = host.substr(1, host.size() - 2);
  } else if (host.find(':') != std::string_view::npos) {
    return std::nullopt;  // IPv6 without brackets
  }
  unsigned port = 0;
  for (const char c : port_text) {
    if (c < '0' || c > '9') return std::nullopt;
    port = port * 10 + static_cast<unsigned>(c - '0');
    if (port > 65535) return std::nullopt;
  }
  return ListenAddress{std::string(host), static_cast<std::uint16_t>(port)};
}

class WsSession;

// Everything below runs on the server thread, but broadcast()'s post and the atomic count.
struct Server::Impl {
  ServerOptions options;
  SnapshotProvider snapshot;
  CommandHandler on_command;
  asio::io_context io{1};
  tcp::acceptor acceptor{io};
  std::set<std::shared_ptr<WsSession>> sessions;
  std::atomic<std::size_t> client_count{0};
  std::thread thread;
  std::uint16_t port = 0;

  void accept();
  void add(const std::shared_ptr<WsSession>& session) {
    sessions.insert(session);
    client_count = sessions.size();
  }
  void remove(const std::shared_ptr<WsSession>& session) {
    sessions.erase(session);
    client_count = sessions.size();
  }
};

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server::Impl& server) : ws_(std::move(socket)), server_(server) {}

  void run(const http::request<http::string_body>& request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(server_.options.max_incoming);
    ws_.text(true);
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) { self->on_accept(ec); });
  }

  void send(std::uint64_t seq, const std::shared_ptr<const std::string>& text) {
    if (seq <= snapshot_seq_) return;  // the snapshot holds it
    enqueue(text);
  }

  void close() {
    closed_ = true;
    beast::error_code ignored;
    beast::get_lowest_layer(ws_).socket().shutdown(tcp::socket::shutdown_both, ignored);
    beast::get_lowest_layer(ws_).socket().close(ignored);
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    Snapshot snap = server_.snapshot();
    snapshot_seq_ = snap.seq;
    server_.add(shared_from_this());
    for (auto& text : snap.texts) enqueue(std::make_shared<const std::string>(std::move(text)));
    read();
  }

  // Reading also keeps the close handshake and pings working.
  void read() {
    ws_.async_read(incoming_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) {
        self->drop();
        return;
      }
      if (self->server_.on_command && self->ws_.got_text()) {
        self->server_.on_command(beast::buffers_to_string(self->incoming_.data()), self->reply_to_me());
      }
      self->incoming_.clear();
      self->read();
    });
  }

  // Answers this browser from any thread, while it is connected.
  Server::Reply reply_to_me() {
    return [weak = weak_from_this(), io = &server_.io](std::string text) {
      auto shared = std::make_shared<const std::string>(std::move(text));
      asio::post(*io, [weak, shared] {
        if (const auto self = weak.lock()) self->enqueue(shared);
      });
    };
  }

  void enqueue(const std::shared_ptr<const std::string>& text) {
    if (closed_) return;
    if (queue_.size() >= server_.options.max_queued) {
      spdlog::warn("web: a browser fell {} messages behind; disconnected (it reconnects from a snapshot)",
                   queue_.size());
      drop();
      return;
    }
    queue_.push_back(text);
    if (queue_.size() == 1) write();
  }

  void write() {
    ws_.async_write(asio::buffer(*queue_.front()), [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) {
        self->drop();
        return;
      }
      self->queue_.pop_front();
      if (!self->queue_.empty() && !self->closed_) self->write();
    });
  }

  void drop() {
    if (!closed_) close();
    server_.remove(shared_from_this());
  }

  websocket::stream<beast::tcp_stream> ws_;
  Server::Impl& server_;
  beast::flat_buffer incoming_;
  std::deque<std::shared_ptr<const std::string>> queue_;
  std::uint64_t snapshot_seq_ = 0;
  bool closed_ = false;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server::Impl& server) : stream_(std::move(socket)), server_(server) {}

  void read() {
    request_ = {};
    stream_.expires_after(kHttpTimeout);
    http::async_read(stream_, buffer_, request_,
                     [self = shared_from_this()](beast::error_code ec, std::size_t) { self->on_read(ec); });
  }

 private:
  void on_read(beast::error_code ec) {
    if (ec == http::error::end_of_stream) {
      stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
      return;
    }
    if (ec) return;
    if (websocket::is_upgrade(request_)) {
      if (!same_origin()) {
        respond(text_response(http::status::forbidden, "WebSocket from another site's page refused\n"));
        return;
      }
      if (request_.target() == "/ws") {
        stream_.expires_never();
        std::make_shared<WsSession>(stream_.release_socket(), server_)->run(request_);
        return;
      }
      respond(text_response(http::status::not_found, "no WebSocket here; the lab's messages are on /ws\n"));
      return;
    }
    respond(file_response());
  }

  // Browsers send the page's origin with a WebSocket handshake, and any page may open one to a
  // local address: only the server's own page (origin http://<Host>) and clients that are no
  // browser (no Origin) may listen to the lab.
  bool same_origin() const {
    const auto origin = request_[http::field::origin];
    if (origin.empty()) return true;
    const auto host = request_[http::field::host];
    return !host.empty() && origin.size() == 7 + host.size() && origin.starts_with("http://") && origin.ends_with(host);
  }

  http::response<http::string_body> text_response(http::status status, std::string body) const {
    http::response<http::string_body> res{status, request_.version()};
    res.set(http::field::content_type, "text/plain; charset=utf-8");
    res.keep_alive(request_.keep_alive());
    res.body() = std::move(body);
    res.prepare_payload();
    return res;
  }

  http::response<http::string_body> file_response() const {
    if (request_.method() != http::verb::get && request_.method() != http::verb::head) {
      auto res =
          text_response(http::status::method_not_allowed, "GET and HEAD only (commands go over the WebSocket)\n");
      res.set(http::field::allow, "GET, HEAD");
      return res;
    }
    const auto target = request_.target();
    const auto path = file_for(server_.options.static_dir, std::string_view(target.data(), target.size()));
    if (!path) return text_response(http::status::bad_request, "bad path\n");
    std::ifstream in(*path, std::ios::binary);
    if (!in || std::filesystem::is_directory(*path)) return text_response(http::status::not_found, "not found\n");
    std::ostringstream content;
    content << in.rdbuf();
    http::response<http::string_body> res{http::status::ok, request_.version()};
    res.set(http::field::content_type, std::string(mime_type(*path)));
    res.set(http::field::cache_control, "no-cache");
    res.keep_alive(request_.keep_alive());
    const bool head = request_.method() == http::verb::head;
    res.body() = head ? std::string() : content.str();
    res.prepare_payload();
    if (head) res.content_length(content.str().size());
    return res;
  }

  void respond(http::response<http::string_body> response) {
    auto res = std::make_shared<http::response<http::string_body>>(std::move(response));
    http::async_write(stream_, *res, [self = shared_from_this(), res](beast::error_code ec, std::size_t) {
      if (ec) return;
      if (res->need_eof()) {
        self->stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
        return;
      }
      self->read();
    });
  }

  beast::tcp_stream stream_;
  Server::Impl& server_;
  beast::flat_buffer buffer_;
  http::request<http::string_body> request_;
};

void Server::Impl::accept() {
  acceptor.async_accept([this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;  // stopping
    if (!ec) std::make_shared<HttpSession>(std::move(socket), *this)->read();
    accept();
  });
}

Server::Server(ServerOptions options, SnapshotProvider snapshot) : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->snapshot = std::move(snapshot);
  const auto& listen = impl_->options.listen;
  const std::string where = "cannot listen on " + endpoint_text(listen) + ": ";
  beast::error_code ec;
  const auto address = asio::ip::make_address(listen.address, ec);
  if (ec) throw std::runtime_error(where + "'" + listen.address + "' is not a numeric IP address");
  const tcp::endpoint endpoint{address, listen.port};
  auto& acceptor = impl_->acceptor;
  acceptor.open(endpoint.protocol(), ec);
  if (!ec) acceptor.set_option(asio::socket_base::reuse_address(true), ec);
  if (!ec) acceptor.bind(endpoint, ec);
  if (!ec) acceptor.listen(asio::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error(where + error_words(ec));
  impl_->port = acceptor.local_endpoint().port();
}

Server::~Server() { stop(); }

void Server::on_command(CommandHandler handler) { impl_->on_command = std::move(handler); }

void Server::start() {
  if (impl_->thread.joinable()) return;
  impl_->accept();
  impl_->thread = std::thread([impl = impl_.get()] {
    try {
      impl->io.run();
    } catch (const std::exception& e) { spdlog::error("web: the server thread ended: {}", e.what()); }
  });
}

void Server::stop() {
  if (!impl_->thread.joinable()) return;
  asio::post(impl_->io, [impl = impl_.get()] {
    beast::error_code ignored;
    impl->acceptor.close(ignored);
    for (const auto& session : impl->sessions) session->close();
    impl->io.stop();
  });
  impl_->thread.join();
}

std::uint16_t Server::port() const { return impl_->port; }

std::string Server::url() const {
  return "http://" + endpoint_text({impl_->options.listen.address, impl_->port}) + "/";
}

std::size_t Server::clients() const { return impl_->client_count; }

void Server::broadcast(Outgoing message) {
  auto text = std::make_shared<const std::string>(std::move(message.text));
  asio::post(impl_->io, [impl = impl_.get(), seq = message.seq, text] {
    const auto sessions = impl->sessions;  // a failing send removes its session
    for (const auto& session : sessions) session->send(seq, text);
  });
}

}  // namespace motion::web
