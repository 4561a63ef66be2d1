// motion-web: a live, read-only web view of the lab. Listens to the lab's LCM channels (AXIS_STATE,
// HEALTH, EVENT, REQUEST, REPLY, ACTIVE_MOVES), turns them into JSON (motion::web::LabView) and
// sends them to every browser over a WebSocket; serves the page (HTML, JS, CSS and Chart.js) from a
// folder of files.
//
// Threads: LCM on the process's EventLoop (the main thread); the HTTP/WebSocket server on its own
// thread. One mutex guards the LabView between the two.
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <string_view>

#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/signed_message_t.hpp>

#include "motion/app/service.hpp"
#include "motion/core/log.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/wire_bounds.hpp"
#include "motion/web/lab_view.hpp"
#include "motion/web/server.hpp"

namespace motion::web {
namespace {

// web/ next to the program (the build tree), else ../share/motion/web (an installed tree).
std::filesystem::path default_static_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "web";
  const auto beside = exe.parent_path() / "web";
  if (std::filesystem::exists(beside / "index.html")) return beside;
  return exe.parent_path().parent_path() / "share" / "motion" / "web";
}

// The LabView and the server it feeds: LCM handlers on the loop thread, snapshots on the server's.
class Bridge {
 public:
  Bridge(const config::Config& config, ServerOptions options)
      : view_(config), server_(std::move(options), [this] {
          const std::lock_guard lock(mutex_);
          return view_.snapshot();
        }) {}

  Server& server() { return server_; }

  // Forwards every message of `channel` through `on` (a LabView member) to the browsers.
  template <typename Msg>
  void forward(lcm::Node& node, std::string_view channel, std::vector<Outgoing> (LabView::*on)(const Msg&)) {
    node.subscribe<Msg>(channel, [this, on](const Msg& msg, const std::string&) {
      std::vector<Outgoing> out;
      {
        const std::lock_guard lock(mutex_);
        out = (view_.*on)(msg);
      }
      for (auto& message : out) server_.broadcast(std::move(message));
    });
  }

  // The same from the coordinator's signed copies (signed_message_t on S<channel>, README
  // "Security"): with security.mode enforce there are no plain ACTIVE_MOVES. Unwrapped without
  // verifying: the view only shows them.
  template <typename Msg>
  void forward_signed(lcm::Node& node, std::string_view channel, std::vector<Outgoing> (LabView::*on)(const Msg&)) {
    node.subscribe<motionlcm::signed_message_t>("S" + std::string(channel), [this, on](const motionlcm::signed_message_t& env, const std::string&) {
      Msg msg;
      if (!lcm::wire::decode_bounded(env.message.data(), env.message.size(), msg).empty()) return;
      std::vector<Outgoing> out;
      {
        const std::lock_guard lock(mutex_);
        out = (view_.*on)(msg);
      }
      for (auto& message : out) server_.broadcast(std::move(message));
    });
  }

  void follow_requests(lcm::Node& node) {
    node.subscribe<motionlcm::request_t>(lcm::channels::kRequest, [this](const motionlcm::request_t& msg, const std::string&) {
      const std::lock_guard lock(mutex_);
      view_.on_request(msg);
    });
  }

 private:
  std::mutex mutex_;
  LabView view_;
  Server server_;
};

}  // namespace
}  // namespace motion::web

int main(int argc, char** argv) {
  using namespace motion;
  CLI::App cli{"motion-web: a live web view of the lab (axes, processes, buses, events, a plot of every move)", "motion-web"};
  app::CommonOptions options;
  app::add_common_options(cli, options);
  std::string listen = "127.0.0.1:8080";
  std::string static_dir;
  cli.add_option("--listen", listen, "ADDR:PORT the web server listens on (port 0: any free port)")->capture_default_str();
  cli.add_option("--static", static_dir, "Folder of the page's files (default: web/ beside the program, else ../share/motion/web)");
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("web", options.log_level)) return app::kExitUsage;
    const auto address = web::parse_listen(listen);
    if (!address) {
      std::cerr << "motion-web: --listen '" << listen << "': expected ADDR:PORT, e.g. 127.0.0.1:8080 or [::1]:8080\n";
      return app::kExitUsage;
    }
    const std::filesystem::path files = static_dir.empty() ? web::default_static_dir() : std::filesystem::path(static_dir);
    if (!std::filesystem::exists(files / "index.html")) {
      std::cerr << "motion-web: no index.html in " << files.string() << " (the page's files; --static names their folder)\n";
      return app::kExitUsage;
    }
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;

    std::unique_ptr<web::Bridge> bridge;
    try {
      bridge = std::make_unique<web::Bridge>(*config, web::ServerOptions{*address, files});
    } catch (const std::runtime_error& e) {
      std::cerr << "motion-web: " << e.what() << "\n";
      return app::kExitUnavailable;
    }
    app::Service service(*config, options, "web", "web");
    if (!service.ok()) return app::kExitUnavailable;
    auto& node = service.node();
    bridge->forward(node, motion::lcm::channels::kAxisState, &web::LabView::on_axis_state);
    bridge->forward(node, motion::lcm::channels::kHealth, &web::LabView::on_health);
    bridge->forward(node, motion::lcm::channels::kEvent, &web::LabView::on_event);
    bridge->forward(node, motion::lcm::channels::kReply, &web::LabView::on_reply);
    bridge->forward(node, motion::lcm::channels::kActiveMoves, &web::LabView::on_active_moves);
    // Under enforce the coordinator sends ACTIVE_MOVES signed only (otherwise plain too: taken once).
    if (config->security.mode == motion::config::SecuritySettings::Mode::kEnforce) bridge->forward_signed(node, motion::lcm::channels::kActiveMoves, &web::LabView::on_active_moves);
    bridge->follow_requests(node);

    auto& server = bridge->server();
    server.start();
    // The address on stdout, alone on its line: for people and for scripts that asked for port 0.
    std::printf("motion-web: serving %s\n", server.url().c_str());
    std::fflush(stdout);
    auto update_health = [&] {
      const auto browsers = server.clients();
      service.health().set_state(motionlcm::health_t::OK, "serving " + server.url() + ", " + std::to_string(browsers) + " browser" +
                                                              (browsers == 1 ? "" : "s"));
    };
    update_health();
    service.loop().call_every(std::chrono::seconds(1), update_health);
    const int code = service.run();
    server.stop();
    return code;
  });
}
