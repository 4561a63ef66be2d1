// motion-web: a live web view of the lab. Listens to the lab's LCM channels (AXIS_STATE, HEALTH,
// EVENT, REQUEST and SREQUEST, REPLY, ACTIVE_MOVES), turns them into JSON (motion::web::LabView) and sends them
// to every browser over a WebSocket; serves the page (HTML, JS, CSS and Chart.js) from a folder of
// files.
//
// With --controls the page may also command the lab (enable, move, jog, stop, e-stop, home, fault
// reset; controls.hpp): motion-web is then a client of the coordinator like motionctl, signing
// with its own key (--key) when security is enforced, so the key's role in authorized_keys is
// what the page may do. A browser's command counts only with the access token motion-web prints
// at start ("controls at http://...?token=..."): anyone else who reaches the port only watches.
//
// Replies (reply_gate.hpp): with security.mode enforce and security.coordinator_public_key the page
// shows only the coordinator's signed replies that verify (SREPLY), and the page's own client
// verifies its replies likewise; otherwise the plain REPLYs. Axis states: with security.mode
// enforce and a readable security.authorized_keys with keys of role gateway, only the gateways'
// signed states that verify (SAXIS_STATE); otherwise the plain AXIS_STATEs (a warning says why).
//
// Threads: LCM and the client on the process's EventLoop (the main thread); the HTTP/WebSocket
// server on its own thread. One mutex guards the LabView between the two; commands from browsers
// reach the main thread through a LoopMailbox.
#include <unistd.h>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <optional>
#include <string_view>
#include <variant>
#include <vector>

#include <spdlog/spdlog.h>
#include <motionlcm/active_moves_t.hpp>
#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/health_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>
#include <motionlcm/signed_message_t.hpp>
#include <motionlcm/signed_request_t.hpp>

#include "motion/app/service.hpp"
#include "motion/client/client.hpp"
#include "motion/core/clock.hpp"
#include "motion/core/log.hpp"
#include "motion/core/loop_mailbox.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/wire_bounds.hpp"
#include "motion/security/authorized_keys.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motion/security/keys.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/web/controls.hpp"
#include "motion/web/lab_view.hpp"
#include "motion/web/reply_gate.hpp"
#include "motion/web/server.hpp"

namespace motion::web {
namespace {

// web/ next to the program (the build tree), else ../share/motion/web (an installed tree).
std::filesystem::path default_static_dir() {
  std::error_code ec;
  const auto exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  if (ec) return "web";
  auto beside = exe.parent_path() / "web";
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
    node.subscribe<motionlcm::signed_message_t>(
        "S" + std::string(channel), [this, on](const motionlcm::signed_message_t& env, const std::string&) {
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

  // Replies through `gate`: the plain ones, or (verifying) only the coordinator's signed ones that
  // verify; the first 10 refused are logged.
  void follow_replies(lcm::Node& node, ReplyGate gate) {
    gate_.emplace(std::move(gate));
    node.subscribe<motionlcm::reply_t>(lcm::channels::kReply,
                                       [this](const motionlcm::reply_t& msg, const std::string&) {
                                         std::vector<Outgoing> out;
                                         {
                                           const std::lock_guard lock(mutex_);
                                           out = gate_->on_plain(view_, msg);
                                         }
                                         for (auto& message : out) server_.broadcast(std::move(message));
                                       });
    if (!gate_->verifies()) return;
    node.subscribe<motionlcm::signed_message_t>(security::signed_channel(lcm::channels::kReply),
                                                [this](const motionlcm::signed_message_t& env, const std::string&) {
                                                  std::vector<Outgoing> out;
                                                  {
                                                    const std::lock_guard lock(mutex_);
                                                    const auto before = gate_->refused();
                                                    out = gate_->on_signed(view_, env, wall_time_us());
                                                    if (gate_->refused() != before && gate_->refused() <= 10) {
                                                      spdlog::warn("web: a reply not shown: {}", gate_->last_refusal());
                                                    }
                                                  }
                                                  for (auto& message : out) server_.broadcast(std::move(message));
                                                });
  }

  // Axis states only from their signed copies (SAXIS_STATE) that verify against `gateways` (the
  // keys of role gateway in authorized_keys; counter per key and bus); the first 10 refused are
  // logged.
  void follow_verified_states(lcm::Node& node, std::vector<security::Principal> gateways,
                              std::chrono::milliseconds window) {
    state_verifier_.emplace(std::move(gateways), "a gateway key", node.prefix(), std::string(lcm::channels::kAxisState),
                            window, wall_time_us());
    node.subscribe<motionlcm::signed_message_t>(security::signed_channel(lcm::channels::kAxisState),
                                                [this](const motionlcm::signed_message_t& env, const std::string&) {
                                                  auto verified = state_verifier_->verify<motionlcm::axis_state_t>(
                                                      env, wall_time_us(),
                                                      [](const motionlcm::axis_state_t& m) { return m.bus; });
                                                  if (!verified.message) {
                                                    if (++refused_states_ <= 10)
                                                      spdlog::warn("web: an axis state not shown: {}", verified.reason);
                                                    return;
                                                  }
                                                  std::vector<Outgoing> out;
                                                  {
                                                    const std::lock_guard lock(mutex_);
                                                    out = view_.on_axis_state(*verified.message);
                                                  }
                                                  for (auto& message : out) server_.broadcast(std::move(message));
                                                });
  }

  // Requests, plain and signed (signed_request_t on SREQUEST, unwrapped without verifying: they
  // only say which requests are moves, and of which kind, for the plots).
  void follow_requests(lcm::Node& node) {
    node.subscribe<motionlcm::request_t>(lcm::channels::kRequest,
                                         [this](const motionlcm::request_t& msg, const std::string&) {
                                           const std::lock_guard lock(mutex_);
                                           view_.on_request(msg);
                                         });
    node.subscribe<motionlcm::signed_request_t>(
        lcm::channels::kSignedRequest, [this](const motionlcm::signed_request_t& env, const std::string&) {
          motionlcm::request_t msg;
          if (!lcm::wire::decode_bounded(env.payload.data(), env.payload.size(), msg).empty()) return;
          const std::lock_guard lock(mutex_);
          view_.on_request(msg);
        });
  }

 private:
  std::mutex mutex_;
  LabView view_;
  Server server_;
  std::optional<ReplyGate> gate_;
  std::optional<security::MessageVerifier> state_verifier_;  // SAXIS_STATE (loop thread only)
  std::uint64_t refused_states_ = 0;
};

// The gateway keys the page verifies axis states with: under enforce, the keys of role gateway in
// security.gateway_public_keys when set, else in authorized_keys, when readable; none (plain
// states, and a warning saying why) otherwise.
std::optional<std::vector<security::Principal>> gateway_keys(const config::Config& config) {
  const auto& settings = config.security;
  if (settings.mode != config::SecuritySettings::Mode::kEnforce) return std::nullopt;
  auto gateways = security::load_gateway_keys(settings.gateway_keys_file());
  if (const auto* error = std::get_if<std::string>(&gateways)) {
    spdlog::warn("web: axis states are shown unverified: {}: {}", settings.gateway_keys_setting(), *error);
    return std::nullopt;
  }
  return std::move(std::get<std::vector<security::Principal>>(gateways));
}

// The page's commands, on the main thread: checked (controls.hpp), then sent by the client.
class Controls {
 public:
  Controls(const config::Config& config, EventLoop& loop, lcm::Node& node, std::string token)
      : config_(config), client_(loop, node, "web"), mailbox_(loop, 256), token_(std::move(token)) {}

  void sign_with(const security::KeyPair& key) { client_.sign_with(key); }
  void verify_with(const security::PublicKey& coordinator, std::chrono::milliseconds window) {
    client_.verify_with(coordinator, window);
  }
  [[nodiscard]] const std::string& token() const { return token_; }

  // On the server thread: hands the command to the main thread, or answers at once when 256 are
  // already waiting.
  void post(std::string text, const Server::Reply& reply) {
    if (!mailbox_.post([this, text = std::move(text), reply] { handle(text, reply); })) {
      reply(control_refused({std::nullopt, "motion-web is busy (256 commands waiting): try again"}));
    }
  }

 private:
  void handle(const std::string& text, const Server::Reply& reply) {
    auto parsed = parse_control(text, config_, token_);
    if (const auto* error = std::get_if<ControlError>(&parsed)) {
      spdlog::warn("web: a browser's command refused: {}", error->error);
      reply(control_refused(*error));
      return;
    }
    auto& command = std::get<ControlRequest>(parsed);
    const std::int64_t id = client_.send(std::move(command.request));
    reply(control_accepted(command.tag, client_.id() + "/" + std::to_string(id)));
  }

  const config::Config& config_;
  client::Client client_;
  LoopMailbox mailbox_;
  const std::string token_;
};

}  // namespace
}  // namespace motion::web

// Only the fixed option set is built outside app::run, which turns every later exception into an exit code.
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  using namespace motion;
  CLI::App cli{"motion-web: a live web view of the lab (axes, processes, buses, events, a plot of every move)",
               "motion-web"};
  app::CommonOptions options;
  app::add_common_options(cli, options);
  std::string listen = "127.0.0.1:8080";
  std::string static_dir;
  bool controls = false;
  std::string key_path;
  cli.add_option("--listen", listen, "ADDR:PORT the web server listens on (port 0: any free port)")
      ->capture_default_str();
  cli.add_option("--static", static_dir,
                 "Folder of the page's files (default: web/ beside the program, else ../share/motion/web)");
  cli.add_flag("--controls", controls,
               "Let the page command the lab (enable, move, jog, stop, e-stop, home, fault reset) with the access "
               "token printed at start");
  cli.add_option(
         "--key", key_path,
         "The web view's private key to sign its requests with (needed by --controls when security is enforced)")
      ->envname("MOTION_WEB_KEY");
  return app::run(cli, argc, argv, [&]() -> int {
    if (!log::init("web", options.log_level)) return app::kExitUsage;
    const auto address = web::parse_listen(listen);
    if (!address) {
      std::cerr << "motion-web: --listen '" << listen << "': expected ADDR:PORT, e.g. 127.0.0.1:8080 or [::1]:8080\n";
      return app::kExitUsage;
    }
    const std::filesystem::path files =
        static_dir.empty() ? web::default_static_dir() : std::filesystem::path(static_dir);
    if (!std::filesystem::exists(files / "index.html")) {
      std::cerr << "motion-web: no index.html in " << files.string()
                << " (the page's files; --static names their folder)\n";
      return app::kExitUsage;
    }
    auto config = app::load_config(options);
    if (!config) return app::kExitConfig;
    std::optional<security::KeyPair> key;
    if (!key_path.empty()) {
      auto loaded = security::load_private_key(key_path);
      if (const auto* error = std::get_if<std::string>(&loaded)) {
        std::cerr << "motion-web: --key: " << *error << "\n";
        return app::kExitConfig;
      }
      key = std::move(std::get<security::KeyPair>(loaded));
    }
    if (controls && !key && config->security.mode == config::SecuritySettings::Mode::kEnforce) {
      std::cerr
          << "motion-web: --controls with security enforced needs --key: the web view's own key, authorized with the "
             "role its page may use (README \"Security\")\n";
      return app::kExitConfig;
    }

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
    if (auto gateways = web::gateway_keys(*config)) {
      bridge->follow_verified_states(node, std::move(*gateways), std::chrono::milliseconds(config->security.window_ms));
    } else {
      bridge->forward(node, motion::lcm::channels::kAxisState, &web::LabView::on_axis_state);
    }
    bridge->forward(node, motion::lcm::channels::kHealth, &web::LabView::on_health);
    bridge->forward(node, motion::lcm::channels::kEvent, &web::LabView::on_event);
    auto gate = web::ReplyGate::from_config(*config, wall_time_us());
    if (const auto* error = std::get_if<std::string>(&gate)) {
      std::cerr << "motion-web: " << config->file << ": " << *error << "\n";
      return app::kExitConfig;
    }
    const bool verifying = std::get<web::ReplyGate>(gate).verifies();
    bridge->follow_replies(node, std::move(std::get<web::ReplyGate>(gate)));
    bridge->forward(node, motion::lcm::channels::kActiveMoves, &web::LabView::on_active_moves);
    // Under enforce the coordinator sends ACTIVE_MOVES signed only (otherwise plain too: taken once).
    if (config->security.mode == motion::config::SecuritySettings::Mode::kEnforce)
      bridge->forward_signed(node, motion::lcm::channels::kActiveMoves, &web::LabView::on_active_moves);
    bridge->follow_requests(node);

    auto& server = bridge->server();
    std::unique_ptr<web::Controls> page_controls;
    if (controls) {
      std::string token = web::new_access_token();
      if (token.empty()) {
        std::cerr << "motion-web: --controls: no random source for the access token\n";
        return app::kExitUnavailable;
      }
      page_controls = std::make_unique<web::Controls>(*config, service.loop(), node, std::move(token));
      if (key) page_controls->sign_with(*key);
      if (verifying) {
        // The same key the gate loaded: only the coordinator's signed replies end the page's requests.
        auto coordinator = security::load_public_key(config->security.coordinator_public_key);
        if (const auto* k = std::get_if<security::PublicKey>(&coordinator)) {
          page_controls->verify_with(*k, std::chrono::milliseconds(config->security.window_ms));
        }
      }
      server.on_command([c = page_controls.get()](std::string text, const web::Server::Reply& reply) {
        c->post(std::move(text), reply);
      });
    } else {
      server.on_command([](const std::string&, const web::Server::Reply& reply) {
        reply(web::control_refused(
            {std::nullopt, "this motion-web is read-only (start it with --controls to command the lab)"}));
      });
    }
    server.start();
    // The address on stdout, alone on its line: for people and for scripts that asked for port 0.
    std::printf("motion-web: serving %s\n", server.url().c_str());
    if (page_controls)
      std::printf("motion-web: controls at %s?token=%s\n", server.url().c_str(), page_controls->token().c_str());
    std::fflush(stdout);
    auto update_health = [&] {
      const auto browsers = server.clients();
      service.health().set_state(motionlcm::health_t::OK, "serving " + server.url() + ", " + std::to_string(browsers) +
                                                              " browser" + (browsers == 1 ? "" : "s"));
    };
    update_health();
    service.loop().call_every(std::chrono::seconds(1), update_health);
    const int code = service.run();
    server.stop();  // no command handler runs after this, so the controls may go
    return code;
  });
}
