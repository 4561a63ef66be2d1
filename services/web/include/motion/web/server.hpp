// The network half of motion-web: an HTTP server (Boost.Beast) for the page's files and a
// WebSocket endpoint (/ws) that sends every browser the lab's JSON messages (lab_view.hpp). Text
// messages a browser sends (at most ServerOptions::max_incoming bytes each; a longer one closes
// its connection) go to the CommandHandler with a way to answer that browser alone; without a
// handler they are read and dropped.
//
// A browser that connects first gets a snapshot (from the SnapshotProvider), then every message
// broadcast after it; messages whose sequence number the snapshot already covers are skipped. A
// browser that falls more than ServerOptions::max_queued messages behind is disconnected (the
// page reconnects and starts again from a snapshot) instead of growing the queue without bound.
//
// A WebSocket handshake that carries an Origin other than the server's own page (http://<Host>)
// is refused (403): another site's page in the same browser cannot read the lab.
//
// Files: GET/HEAD of paths under ServerOptions::static_dir ("/" is index.html); names with "..",
// hidden files and other methods are refused.
//
// Thread contract: the constructor binds and listens on the caller's thread; start() runs the
// server on a thread of its own, which calls the SnapshotProvider and the CommandHandler (both
// must be safe to call from it; the handler must not block). A Reply may be called from any
// thread, later too: it answers its browser if that one is still connected. on_command() before
// start(). broadcast() and clients() may be called from any thread and never block. stop() (and
// the destructor) blocks until the server thread has ended; call it from the thread that owns the
// Server.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>

#include "motion/web/lab_view.hpp"

namespace motion::web {

struct ListenAddress {
  std::string address;  // numeric IPv4 or IPv6 address
  std::uint16_t port = 0;
};
// "ADDR:PORT" ("[v6]:PORT" for IPv6); nullopt when it is not that form.
[[nodiscard]] std::optional<ListenAddress> parse_listen(std::string_view text);

struct ServerOptions {
  ListenAddress listen{"127.0.0.1", 8080};  // port 0: a free port (see Server::port())
  std::filesystem::path static_dir;
  std::size_t max_queued = 20000;                     // messages per browser not yet written
  std::size_t max_incoming = std::size_t{16} * 1024;  // bytes of one message from a browser
};

class Server {
 public:
  using SnapshotProvider = std::function<Snapshot()>;
  using Reply = std::function<void(std::string text)>;
  using CommandHandler = std::function<void(std::string text, Reply reply)>;

  // Binds and listens. Throws std::runtime_error naming the address and why, e.g. "cannot listen
  // on 127.0.0.1:8080: address in use".
  Server(ServerOptions options, SnapshotProvider snapshot);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  void on_command(CommandHandler handler);
  void start();
  void stop();

  // The port bound (the one asked for, or the one the system chose for port 0).
  [[nodiscard]] std::uint16_t port() const;
  // "http://ADDR:PORT/"
  [[nodiscard]] std::string url() const;
  [[nodiscard]] std::size_t clients() const;

  void broadcast(Outgoing message);

  struct Impl;  // the server thread's state (server.cpp)

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace motion::web
