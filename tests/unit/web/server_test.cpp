// The web server on a loopback port of its own: the page's files (and nothing outside their
// folder), a clear error for a port in use, and the WebSocket: snapshot first, then only the
// broadcasts the snapshot does not already hold.
#include "motion/web/server.hpp"

#include <gtest/gtest.h>

#include <unistd.h>

#include <chrono>
#include <fstream>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
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

class ServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("motion-web-test-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_ / "vendor");
    std::ofstream(dir_ / "index.html") << "<html>lab</html>";
    std::ofstream(dir_ / "vendor" / "lib.js") << "var x = 1;";
    std::ofstream(dir_ / ".hidden") << "secret";
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  ServerOptions options() const { return ServerOptions{{"127.0.0.1", 0}, dir_}; }

  http::response<http::string_body> get(std::uint16_t port, const std::string& target,
                                        http::verb verb = http::verb::get) {
    asio::io_context io;
    beast::tcp_stream stream(io);
    stream.connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), port));
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, "127.0.0.1");
    http::write(stream, req);
    beast::flat_buffer buffer;
    http::response<http::string_body> res;
    http::read(stream, buffer, res);
    return res;
  }

  std::filesystem::path dir_;
};

TEST(ParseListen, AddressAndPort) {
  const auto v4 = parse_listen("127.0.0.1:8080");
  ASSERT_TRUE(v4);
  EXPECT_EQ(v4->address, "127.0.0.1");
  EXPECT_EQ(v4->port, 8080);
  const auto v6 = parse_listen("[::1]:0");
  ASSERT_TRUE(v6);
  EXPECT_EQ(v6->address, "::1");
  EXPECT_EQ(v6->port, 0);
  EXPECT_FALSE(parse_listen("8080"));
  EXPECT_FALSE(parse_listen("127.0.0.1:"));
  EXPECT_FALSE(parse_listen(":8080"));
  EXPECT_FALSE(parse_listen("127.0.0.1:65536"));
  EXPECT_FALSE(parse_listen("127.0.0.1:80x"));
  EXPECT_FALSE(parse_listen("::1:8080"));
}

TEST_F(ServerTest, APortInUseIsNamedInTheError) {
  Server first(options(), [] { return Snapshot{}; });
  ServerOptions same = options();
  same.listen.port = first.port();
  try {
    Server second(same, [] { return Snapshot{}; });
    FAIL() << "a second server listened on the same port";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "cannot listen on 127.0.0.1:" + std::to_string(first.port()) + ": address in use");
  }
  ServerOptions bad = options();
  bad.listen.address = "localhost";
  EXPECT_THROW(Server(bad, [] { return Snapshot{}; }), std::runtime_error);
}

TEST_F(ServerTest, ServesThePageFilesAndNothingElse) {
  Server server(options(), [] { return Snapshot{}; });
  server.start();
  EXPECT_EQ(server.url(), "http://127.0.0.1:" + std::to_string(server.port()) + "/");

  auto res = get(server.port(), "/");
  EXPECT_EQ(res.result(), http::status::ok);
  EXPECT_EQ(res.body(), "<html>lab</html>");
  EXPECT_EQ(res[http::field::content_type], "text/html; charset=utf-8");
  res = get(server.port(), "/vendor/lib.js?v=1");
  EXPECT_EQ(res.result(), http::status::ok);
  EXPECT_EQ(res[http::field::content_type], "text/javascript; charset=utf-8");
  EXPECT_EQ(get(server.port(), "/missing.html").result(), http::status::not_found);
  EXPECT_EQ(get(server.port(), "/../index.html").result(), http::status::bad_request);
  EXPECT_EQ(get(server.port(), "/vendor/../../etc/passwd").result(), http::status::bad_request);
  EXPECT_EQ(get(server.port(), "/.hidden").result(), http::status::bad_request);
  EXPECT_EQ(get(server.port(), "/", http::verb::post).result(), http::status::method_not_allowed);
  server.stop();
}

TEST_F(ServerTest, ABrowserGetsTheSnapshotThenWhatFollowsIt) {
  Server server(options(), [] { return Snapshot{2, {"{\"n\":1}", "{\"n\":2}"}}; });
  server.start();

  asio::io_context io;
  websocket::stream<beast::tcp_stream> ws(io);
  beast::get_lowest_layer(ws).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
  ws.handshake("127.0.0.1", "/ws");
  auto next = [&ws] {
    beast::flat_buffer buffer;
    ws.read(buffer);
    return beast::buffers_to_string(buffer.data());
  };
  EXPECT_EQ(next(), "{\"n\":1}");
  EXPECT_EQ(next(), "{\"n\":2}");

  // The server has registered the browser once it sent the snapshot; the count follows.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (server.clients() == 0 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  EXPECT_EQ(server.clients(), 1u);
  server.broadcast({2, "{\"n\":2}"});  // already in the snapshot
  server.broadcast({3, "{\"n\":3}"});
  EXPECT_EQ(next(), "{\"n\":3}");

  ws.close(websocket::close_code::normal);
  server.stop();
}

TEST_F(ServerTest, ABrowsersMessageReachesTheCommandHandlerAndTheAnswerOnlyThatBrowser) {
  Server server(options(), [] { return Snapshot{1, {"{\"n\":1}"}}; });
  std::mutex mutex;
  std::vector<std::string> received;
  server.on_command([&](const std::string& text, const Server::Reply& reply) {
    {
      const std::lock_guard lock(mutex);
      received.push_back(text);
    }
    // Answered from another thread, as motion-web's main thread does.
    std::thread([reply, text] { reply("answer to " + text); }).detach();
  });
  server.start();

  asio::io_context io;
  auto open = [&] {
    auto ws = std::make_unique<websocket::stream<beast::tcp_stream>>(io);
    beast::get_lowest_layer(*ws).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
    ws->handshake("127.0.0.1", "/ws");
    return ws;
  };
  auto next = [](websocket::stream<beast::tcp_stream>& ws) {
    beast::flat_buffer buffer;
    ws.read(buffer);
    return beast::buffers_to_string(buffer.data());
  };
  auto sender = open();
  auto watcher = open();
  EXPECT_EQ(next(*sender), "{\"n\":1}");
  EXPECT_EQ(next(*watcher), "{\"n\":1}");
  sender->write(asio::buffer(std::string("{\"type\":\"command\",\"tag\":1}")));
  EXPECT_EQ(next(*sender), "answer to {\"type\":\"command\",\"tag\":1}");
  {
    const std::lock_guard lock(mutex);
    EXPECT_EQ(received, (std::vector<std::string>{"{\"type\":\"command\",\"tag\":1}"}));
  }
  // The watcher got no answer: the next thing it reads is the next broadcast.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (server.clients() < 2 && std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  server.broadcast({2, "{\"n\":2}"});
  EXPECT_EQ(next(*watcher), "{\"n\":2}");
  EXPECT_EQ(next(*sender), "{\"n\":2}");

  // A message longer than max_incoming closes that browser's connection; the handler never sees it.
  sender->write(asio::buffer(std::string(options().max_incoming + 1, 'x')));
  beast::flat_buffer buffer;
  beast::error_code ec;
  sender->read(buffer, ec);
  EXPECT_TRUE(ec) << "the oversized message's sender is still connected";
  {
    const std::lock_guard lock(mutex);
    EXPECT_EQ(received.size(), 1u);
  }
  server.stop();
}

TEST_F(ServerTest, AnotherSitesPageCannotOpenTheWebSocket) {
  Server server(options(), [] { return Snapshot{1, {"{}"}}; });
  server.start();
  const std::string host = "127.0.0.1:" + std::to_string(server.port());
  auto handshake = [&](const std::string& origin) {
    asio::io_context io;
    websocket::stream<beast::tcp_stream> ws(io);
    beast::get_lowest_layer(ws).connect(tcp::endpoint(asio::ip::make_address("127.0.0.1"), server.port()));
    ws.set_option(websocket::stream_base::decorator(
        [origin](websocket::request_type& req) { req.set(http::field::origin, origin); }));
    beast::error_code ec;
    ws.handshake(host, "/ws", ec);
    return !ec;
  };
  EXPECT_TRUE(handshake("http://" + host));
  EXPECT_FALSE(handshake("http://evil.example"));
  EXPECT_FALSE(handshake("http://" + host + ".evil.example"));
  server.stop();
}

}  // namespace
}  // namespace motion::web
