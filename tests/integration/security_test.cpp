// Signed requests end to end on a simulated lab with `security: {mode: enforce}`
// (tests/integration/configs/uim342-three-group.yaml plus a security section and an
// authorized_keys file written by the test): a signed move of an `operate` key runs; each way of
// being refused says why (in the reply when the request is authentic, else in a SECURITY event)
// and moves nothing. The coordinator signs its gateway commands; a command straight on
// GW_COMMAND_<bus>, or one signed with another key, is refused by the gateway, and so are triggers
// and ACTIVE_MOVES not signed by the coordinator. A client holding the coordinator's public key
// takes no forged REPLY. One lab serves the whole suite to keep it short.
#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <variant>

#include <motionlcm/signed_request_t.hpp>

#include "motion/lcm/gateway_commands.hpp"
#include "motion/security/gateway_commands.hpp"
#include "motion/security/signed_messages.hpp"
#include "motion/security/signed_request.hpp"
#include "motion/testing/lab_keys.hpp"
#include "motion/testing/temp_dir.hpp"
#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::signed_request_t;
namespace fs = std::filesystem;

const std::vector<std::string> kAxes{"x1", "w"};
constexpr double kTolerance = 1.0 / 640.0 + 1e-9;  // one micro-step, mm

bool contains(const std::string& text, const std::string& part) { return text.find(part) != std::string::npos; }

class Security : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir("motion-security");
    keys_ = new Keys{security::KeyPair::generate("admin"), security::KeyPair::generate("op"),
                     security::KeyPair::generate("watch"), security::KeyPair::generate("stranger")};
    {
      std::ifstream base(source_path("tests/integration/configs/uim342-three-group.yaml"));
      std::ofstream config(dir_->str() + "/lab.yaml");
      config << base.rdbuf() << motion::testing::enforced_security(2000);
    }
    ASSERT_EQ(motion::testing::write_lab_keys(
                  dir_->str(), {keys_->admin.authorized_line("admin"), keys_->op.authorized_line("operate"),
                                keys_->watch.authorized_line("observe")}),
              std::nullopt);
    ASSERT_EQ(security::write_key_pair(keys_->op, dir_->str(), "operate"), std::nullopt);  // for motionctl --key
    lab_ = new SimLab(dir_->str() + "/lab.yaml");
    clients_ = new std::vector<std::unique_ptr<Client>>;
    heard_ = new std::vector<signed_request_t>;
    // What an eavesdropper records.
    lab_->group().node().subscribe<signed_request_t>(
        lcm::channels::kSignedRequest, [](const signed_request_t& m, const std::string&) { heard_->push_back(m); });
    lab_->client().sign_with(keys_->admin);  // the lab's own client enables the axes
    ASSERT_TRUE(lab_->start(kAxes));
    ASSERT_TRUE(lab_->enable(kAxes));
  }
  static void TearDownTestSuite() {
    delete lab_;  // kills every process of the lab, and its node: no handler runs after this
    lab_ = nullptr;
    delete clients_;
    delete heard_;
    delete keys_;
    delete dir_;
  }
  void SetUp() override {
    ASSERT_NE(lab_, nullptr);
    lab_->clear_reports();
    for (const auto& a : kAxes) before_[a] = lab_->position(a);
  }
  void TearDown() override {
    if (HasFailure()) lab_->group().print_logs();
  }

  static request_t move_to(const std::string& axis, double target, std::int8_t kind = request_t::MOVE_ABSOLUTE) {
    return Client::make(kind, std::map<std::string, double>{{axis, target}});
  }
  // A client of its own on the lab's node, signing with `key` (none: unsigned). It lives as long
  // as the node (whose subscriptions call it).
  static Client* client(const std::string& id, const security::KeyPair* key) {
    auto& c = clients_->emplace_back(std::make_unique<Client>(lab_->group().loop(), lab_->group().node(), id));
    if (key != nullptr) c->sign_with(*key);
    return c.get();
  }
  // Publishes `envelope` as it is on SREQUEST and waits for a SECURITY event containing `text`.
  bool refused_with(const signed_request_t& envelope, const std::string& text) {
    lab_->group().node().publish(lcm::channels::kSignedRequest, envelope);
    return lab_->client().wait_until([&] { return lab_->has_event(motionlcm::event_t::SECURITY, "", text); },
                                     seconds(3));
  }
  // Nothing moved since SetUp: no drive started, every axis where it was.
  void expect_nothing_moved() {
    lab_->pause(milliseconds(300));  // a start, had there been one, would be reported by now
    for (const auto& d : lab_->config().drives) EXPECT_TRUE(lab_->starts_of(d.name).empty()) << d.name << " started";
    for (const auto& a : kAxes) EXPECT_NEAR(lab_->position(a), before_[a], kTolerance) << a;
  }

  struct Keys {
    security::KeyPair admin, op, watch, stranger;
  };
  static testing::TempDir* dir_;  // removed with its contents on delete
  static Keys* keys_;
  static SimLab* lab_;
  static std::vector<std::unique_ptr<Client>>* clients_;
  static std::vector<signed_request_t>* heard_;
  std::map<std::string, double> before_;
};

testing::TempDir* Security::dir_ = nullptr;
Security::Keys* Security::keys_ = nullptr;
SimLab* Security::lab_ = nullptr;
std::vector<std::unique_ptr<Client>>* Security::clients_ = nullptr;
std::vector<signed_request_t>* Security::heard_ = nullptr;

TEST_F(Security, SignedMoveOfAnOperateKeyEndsDoneAtItsTarget) {
  const auto op = client("ctl", &keys_->op);
  EXPECT_EQ(op->id(), "op/ctl");
  const double target = before_["w"] + 2.0;
  const reply_t done = op->call(move_to("w", target), seconds(20));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  EXPECT_EQ(done.client_id, "op/ctl");
  EXPECT_TRUE(lab_->settled_at("w", target, kTolerance));
}

TEST_F(Security, MotionctlSignsWithItsKeyAndRefusesWithoutOne) {
  const std::string config = dir_->str() + "/lab.yaml";
  const std::string url = lab_->group().lcm_url();
  const double target = before_["w"] - 1.0;
  std::string out;
  const int rc = lab_->group().run_to_completion(
      {"motionctl",
       "motionctl",
       {"--config", config, "--key", dir_->str() + "/op.key", "move", "w=" + std::to_string(target), "--wait"},
       {}},
      &out, seconds(20));
  EXPECT_EQ(rc, 0) << out;
  EXPECT_TRUE(lab_->settled_at("w", target, kTolerance));
  lab_->clear_reports();
  before_["w"] = lab_->position("w");
  const int plain_rc = lab_->group().run_to_completion(
      {"motionctl-plain", "motionctl", {"--config", config, "move", "w=0", "--wait"}, {}}, &out, seconds(20));
  EXPECT_EQ(plain_rc, 1) << out;
  EXPECT_TRUE(contains(out, "unsigned request refused: security is enforced")) << out;
  expect_nothing_moved();
}

TEST_F(Security, PlainRequestIsRefusedWithASecurityEventAndNoReply) {
  const auto plain = client("plain", nullptr);
  std::vector<reply_t> replies;
  const reply_t r =
      plain->call(move_to("w", before_["w"] + 3), seconds(5), [&](const reply_t& p) { replies.push_back(p); });
  EXPECT_EQ(r.status, st(reply_t::REJECTED)) << r.reason;
  EXPECT_EQ(r.error_code, code(ReplyError::kUnauthorized));
  // The rejection is the client's own, from the SECURITY event: the coordinator sent nothing.
  EXPECT_TRUE(contains(r.reason,
                       "refused by the coordinator's security (SECURITY event, no reply): unsigned request refused: "
                       "security is enforced "
                       "(move request " +
                           std::to_string(r.request_id) + " of client 'plain'"))
      << r.reason;
  EXPECT_TRUE(replies.empty());
  expect_nothing_moved();
}

TEST_F(Security, UnknownKeyIsRefused) {
  const auto stranger = client("ctl", &keys_->stranger);
  const reply_t r = stranger->call(move_to("w", before_["w"] + 3), seconds(5));
  EXPECT_EQ(r.status, st(reply_t::REJECTED));
  EXPECT_TRUE(contains(r.reason, "signed request refused: unknown key " + security::to_hex(keys_->stranger.id()) +
                                     " (not in authorized_keys)"))
      << r.reason;
  expect_nothing_moved();
}

TEST_F(Security, WrongSignatureAndTamperedPayloadAreRefused) {
  security::RequestSigner op(keys_->op, "MOTION_");
  auto request = move_to("w", before_["w"] + 3);
  request.client_id = "op";
  signed_request_t forged = op.sign(request, wall_time_us());
  forged.signature[5] ^= 0x10;
  EXPECT_TRUE(refused_with(forged, "signed request refused: bad signature from key 'op'"));
  // The signed move of 3 mm altered in transit to one of 4 mm.
  signed_request_t tampered = op.sign(request, wall_time_us());
  request.values[0] = before_["w"] + 4;
  const int size = request.getEncodedSize();
  ASSERT_EQ(size, tampered.payload_size);
  request.encode(tampered.payload.data(), 0, size);
  EXPECT_TRUE(refused_with(tampered, "bad signature from key 'op' (" + security::to_hex(keys_->op.id()) +
                                         ") (forged or altered in transit)"));
  expect_nothing_moved();
}

TEST_F(Security, ReplayedCounterAndStaleTimestampAreRefused) {
  // The operator's signed ENABLE runs once; what an eavesdropper recorded of it is refused.
  heard_->clear();
  const auto op = client("ctl", &keys_->op);
  const reply_t enabled = op->call(Client::make(request_t::ENABLE, std::vector<std::string>{"w"}), seconds(10));
  ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;
  ASSERT_EQ(heard_->size(), 1u);
  const signed_request_t recorded = heard_->front();
  EXPECT_TRUE(refused_with(recorded, "replayed counter " + std::to_string(recorded.counter) + " from key 'op'"));
  // Signed 10 s ago (before this coordinator started), and 10 s ahead (the window is 2 s).
  security::RequestSigner late(keys_->op, "MOTION_");
  request_t move = move_to("w", before_["w"] + 3);
  move.client_id = "op/late";
  EXPECT_TRUE(refused_with(late.sign(move, wall_time_us() - 10'000'000), "stale timestamp from key 'op'"));
  security::RequestSigner early(keys_->op, "MOTION_");
  EXPECT_TRUE(
      refused_with(early.sign(move, wall_time_us() + 10'000'000), "ms in the future, outside the window of 2000 ms"));
  expect_nothing_moved();
}

TEST_F(Security, RoleTooLowIsRejectedInTheReply) {
  const auto watch = client("ctl", &keys_->watch);
  const reply_t moved = watch->call(move_to("w", before_["w"] + 3), seconds(5));
  EXPECT_EQ(moved.status, st(reply_t::REJECTED));
  EXPECT_EQ(moved.error_code, code(ReplyError::kUnauthorized));
  EXPECT_TRUE(contains(moved.reason, "role too low: key 'watch' (" + security::to_hex(keys_->watch.id()) +
                                         ") has role observe, a move needs operate"))
      << moved.reason;
  const auto op = client("ctl", &keys_->op);
  const reply_t set = op->call(move_to("w", 0.0, request_t::SET_POSITION), seconds(5));
  EXPECT_EQ(set.status, st(reply_t::REJECTED));
  EXPECT_EQ(set.error_code, code(ReplyError::kUnauthorized));
  EXPECT_TRUE(contains(set.reason, "has role operate, a set position needs configure")) << set.reason;
  // Every principal may stop.
  const reply_t stop = watch->call(Client::make(request_t::STOP, std::vector<std::string>{"w"}), seconds(10));
  EXPECT_EQ(stop.status, st(reply_t::DONE)) << stop.reason;
  expect_nothing_moved();
}

TEST_F(Security, GatewayRefusesCommandsNotSignedByTheCoordinator) {
  // A jog of w at 5 mm/s, as the coordinator would send it, straight to the gateway.
  motionlcm::gateway_command_t jog{};
  jog.utime = wall_time_us();
  jog.bus = "can0";
  jog.command_id = 900001;
  jog.request_id = 900001;
  jog.kind = motionlcm::gateway_command_t::JOG;
  motionlcm::axis_command_t w{};
  w.axis = "w";
  w.velocity = 5 * 640;
  jog.axes = {w};
  jog.num_axes = 1;
  lab_->group().node().publish(lcm::channels::gateway_command("can0"), jog);
  EXPECT_TRUE(lab_->client().wait_until(
      [&] {
        return lab_->has_event(motionlcm::event_t::SECURITY, "",
                               "unsigned command 900001 (request 900001) refused: security is enforced");
      },
      seconds(3)));
  security::GatewayCommandSigner impostor(security::KeyPair::generate("coordinator"), "MOTION_");
  jog.command_id = 900002;
  lab_->group().node().publish(lcm::channels::signed_gateway_command("can0"), impostor.sign(jog, wall_time_us()));
  EXPECT_TRUE(lab_->client().wait_until(
      [&] { return lab_->has_event(motionlcm::event_t::SECURITY, "", "is not the coordinator's"); }, seconds(3)));
  expect_nothing_moved();
}

TEST_F(Security, ForgedReplyForAPendingRequestDoesNotEndItWhenTheClientVerifies) {
  const auto op = client("verifying", &keys_->op);
  const auto coordinator = security::load_public_key(dir_->str() + "/coordinator.pub");
  ASSERT_TRUE(std::holds_alternative<security::PublicKey>(coordinator));
  op->verify_with(std::get<security::PublicKey>(coordinator), milliseconds(2000));
  const double target = before_["w"] + 2.0;
  std::vector<reply_t> seen;
  bool forged = false;
  security::MessageSigner impostor(security::KeyPair::generate("coordinator"), "MOTION_");
  const std::int64_t id = op->send(move_to("w", target), [&](const reply_t& r) {
    seen.push_back(r);
    if (forged) return;
    forged = true;
    // The moment the move is accepted, an attacker says it failed: plain on REPLY, and signed
    // with a key of its own on SREPLY.
    reply_t lie{};
    lie.utime = wall_time_us();
    lie.client_id = r.client_id;
    lie.request_id = r.request_id;
    lie.status = reply_t::FAILED;
    lie.reason = "forged";
    lab_->group().node().publish(lcm::channels::kReply, lie);
    lab_->group().node().publish(security::signed_channel(lcm::channels::kReply),
                                 impostor.sign(lcm::channels::kReply, lie, wall_time_us()));
  });
  ASSERT_TRUE(op->wait_until([&] { return !seen.empty() && client::is_terminal(seen.back().status); }, seconds(20)));
  for (const auto& r : seen) EXPECT_NE(r.reason, "forged") << "the client took a forged reply of request " << id;
  EXPECT_EQ(seen.back().status, st(reply_t::DONE)) << seen.back().reason;
  EXPECT_EQ(op->forged_replies(), 1u);  // the signed one; the plain one is not even a candidate
  EXPECT_TRUE(lab_->settled_at("w", target, kTolerance));
  // A client that does not verify would have ended on the lie: the forgery did reach the wire.
}

TEST_F(Security, GatewaysActOnNoTriggerOrActiveMovesNotSignedByTheCoordinator) {
  motionlcm::sync_trigger2_t trigger{};
  trigger.trigger_id = 424242;
  trigger.act_utime = wall_time_us();
  trigger.buses = {"can0"};
  trigger.send_utime = {trigger.act_utime};
  trigger.lead_us = {0.0};
  trigger.num_buses = 1;
  lab_->group().node().publish(lcm::channels::kSyncTrigger2, trigger);
  EXPECT_TRUE(lab_->client().wait_until(
      [&] {
        return lab_->has_event(event_t::SECURITY, "",
                               "unsigned SYNC_TRIGGER2 (trigger 424242) refused: security is enforced");
      },
      seconds(3)));
  security::MessageSigner impostor(security::KeyPair::generate("coordinator"), "MOTION_");
  trigger.trigger_id = 424243;
  lab_->group().node().publish(security::signed_channel(lcm::channels::kSyncTrigger2),
                               impostor.sign(lcm::channels::kSyncTrigger2, trigger, wall_time_us()));
  EXPECT_TRUE(lab_->client().wait_until(
      [&] { return lab_->has_event(event_t::SECURITY, "", "signed SYNC_TRIGGER2 refused: key"); }, seconds(3)));
  // A desired state saying w moves since long ago: a gateway taking it would stop w, and say so.
  motionlcm::active_moves_t moves{};
  moves.axes = {"w"};
  moves.buses = {"can0"};
  moves.client_ids = {"op/ghost"};
  moves.request_ids = {7};
  moves.kinds = {request_t::MOVE_ABSOLUTE};
  moves.phases = {motionlcm::active_moves_t::MOVING};
  moves.command_ids = {7};
  moves.target_counts = {0};
  moves.targets = {0.0};
  moves.fire_utime = {wall_time_us() - 60'000'000};
  moves.num_axes = 1;
  lab_->group().node().publish(lcm::channels::kActiveMoves, moves);
  EXPECT_TRUE(lab_->client().wait_until(
      [&] { return lab_->has_event(event_t::SECURITY, "", "unsigned ACTIVE_MOVES (1 rows) refused"); }, seconds(3)));
  lab_->pause(milliseconds(200));
  EXPECT_FALSE(lab_->has_event(event_t::GATEWAY_RESTARTED, "w", "op/ghost"));
  expect_nothing_moved();
}

// What gateways publish is signed (security.gateway_key): axis states saying x1 is faulted and
// offline, plain and signed with a key that is no gateway's, change nothing in the coordinator's
// view, nor in that of a client verifying states with the gateway key. A move of x1 sent right
// behind them runs and ends DONE at its target; the signed forgery is reported in a SECURITY event.
TEST_F(Security, ForgedAxisStatesChangeNothingInTheCoordinatorsView) {
  const config::Axis* axis = lab_->config().find_axis("x1");
  ASSERT_NE(axis, nullptr);
  motionlcm::axis_state_t forged{};
  forged.axis = "x1";
  forged.bus = lab_->config().drive_of(*axis)->bus;
  forged.family = "uim342";
  forged.fault = true;
  forged.fault_text = "forged";
  // A client that verifies axis states with the gateways' key (role gateway in authorized_keys).
  Client* watcher = client("watcher", nullptr);
  auto gateway_key = security::load_gateway_keys(dir_->str() + "/gateway.pub");
  ASSERT_TRUE(std::holds_alternative<std::vector<security::Principal>>(gateway_key));
  watcher->verify_states_with(std::move(std::get<std::vector<security::Principal>>(gateway_key)), seconds(2));
  ASSERT_TRUE(watcher->wait_until([&] { return watcher->axes().contains("x1"); }, seconds(3)));
  security::MessageSigner forger(keys_->stranger, lab_->group().node().prefix());
  for (int i = 0; i < 3; ++i) {
    forged.utime = forged.sample_utime = wall_time_us();
    lab_->group().node().publish(lcm::channels::kAxisState, forged);
    lab_->group().node().publish(security::signed_channel(lcm::channels::kAxisState),
                                 forger.sign(lcm::channels::kAxisState, forged, wall_time_us()));
  }
  const auto op = client("after-forgery", &keys_->op);
  const double target = before_["x1"] + 1.0;
  const reply_t done = op->call(move_to("x1", target), seconds(20));
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  EXPECT_TRUE(lab_->settled_at("x1", target, kTolerance));
  // The verifying client never took the forgery: its x1 is where the move put it, not faulted.
  EXPECT_EQ(watcher->forged_states(), 3u);
  ASSERT_TRUE(watcher->wait_until([&] { return std::abs(watcher->axes().at("x1").position - target) <= kTolerance; },
                                  seconds(3)));
  EXPECT_FALSE(watcher->axes().at("x1").fault);
  EXPECT_TRUE(lab_->client().wait_until(
      [&] {
        return lab_->has_event(event_t::SECURITY, "",
                               "signed AXIS_STATE refused: key " + security::to_hex(keys_->stranger.id()) +
                                   " is not a key of role gateway in authorized_keys");
      },
      seconds(3)));
}

// motionctl verifies axis states with security.gateway_public_keys when it is set (a file of public
// keys only, in authorized_keys' format: here the gateways' .pub file), for an operator who cannot
// read authorized_keys: with the gateways' key the states are shown and verified; with a file
// holding another gateway key only, none is shown; without the setting, motionctl falls back to
// authorized_keys and, unable to read it, shows the states unverified and says so.
TEST_F(Security, MotionctlVerifiesStatesWithTheGatewayPublicKeysFile) {
  {
    std::ofstream(dir_->str() + "/other-gateway.pub")
        << security::KeyPair::generate("gateway-elsewhere").authorized_line("gateway") << "\n";
  }
  const auto status = [&](const std::string& name, const std::string& gateway_public_keys, std::string& out) {
    const std::string path = dir_->str() + "/" + name + ".yaml";
    {
      std::ifstream base(source_path("tests/integration/configs/uim342-three-group.yaml"));
      std::ofstream config(path);
      config << base.rdbuf()
             << motion::testing::enforced_security(
                    2000, "no-such-authorized_keys",
                    gateway_public_keys.empty() ? "" : "  gateway_public_keys: " + gateway_public_keys + "\n");
    }
    return lab_->group().run_to_completion({name, "motionctl", {"--config", path, "status", "--listen", "1"}, {}}, &out,
                                           seconds(20));
  };
  std::string verified, foreign, fallback;
  EXPECT_EQ(status("ctl-gateway-keys", "gateway.pub", verified), 0) << verified;
  EXPECT_FALSE(contains(verified, "unverified")) << verified;
  const auto x1 = verified.find("\nx1 ");
  ASSERT_NE(x1, std::string::npos) << verified;
  EXPECT_FALSE(contains(verified.substr(x1 + 1, verified.find('\n', x1 + 1) - x1 - 1), "no state heard")) << verified;
  EXPECT_EQ(status("ctl-other-keys", "other-gateway.pub", foreign), 4) << foreign;  // kExitUnavailable: no state
  EXPECT_FALSE(contains(foreign, "unverified")) << foreign;
  EXPECT_EQ(status("ctl-no-gateway-keys", "", fallback), 0) << fallback;
  EXPECT_TRUE(contains(fallback,
                       "motionctl: axis states are shown unverified: security.authorized_keys: cannot read "
                       "authorized keys file"))
      << fallback;
}

TEST_F(Security, SimulatorsRuntimeFolderAndBusSocketAreItsOwnersAlone) {
  // As motion-sim made them: set explicitly (by the umask alone the folder would be 0777 less it).
  const fs::path dir = lab_->group().work_dir() + "/sim";
  struct stat st {};
  ASSERT_EQ(::lstat(dir.c_str(), &st), 0);
  EXPECT_TRUE(S_ISDIR(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0700U);
  ASSERT_EQ(::stat((dir / "motion-simbus-can0.sock").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0600U);
}

// The coordinator signs gateway_command2_t (every signed move of this suite is one); a
// gateway_command_t signed with the coordinator's key is still executed, and an unsigned
// gateway_command2_t on GW_COMMAND2_<bus> is refused like an unsigned gateway_command_t. (Last:
// its SECURITY event would count against the gateway's 5 a second of the tests before it.)
TEST_F(Security, GatewayTakesEitherCommandVersionSignedByTheCoordinator) {
  auto loaded = security::load_private_key(dir_->str() + "/coordinator.key");
  ASSERT_TRUE(std::holds_alternative<security::KeyPair>(loaded)) << std::get<std::string>(loaded);
  security::GatewayCommandSigner coordinator(std::get<security::KeyPair>(loaded), "MOTION_");
  // Command id -> status, from SGW_REPLY (the subscription outlives the test: shared).
  auto heard = std::make_shared<std::map<std::int64_t, std::int8_t>>();
  lab_->group().node().subscribe<motionlcm::signed_message_t>(
      security::signed_channel(lcm::channels::kGatewayReply),
      [heard](const motionlcm::signed_message_t& m, const std::string&) {
        motionlcm::gateway_reply_t r{};
        if (r.decode(m.message.data(), 0, m.message_size) == m.message_size) (*heard)[r.command_id] = r.status;
      });
  auto& replied = *heard;
  motionlcm::gateway_command_t enable{};  // the axes are enabled: an ENABLE moves nothing
  enable.utime = wall_time_us();
  enable.bus = "can0";
  enable.command_id = 900101;
  enable.kind = motionlcm::gateway_command_t::ENABLE;
  enable.axes.resize(1);
  enable.axes[0].axis = "w";
  enable.num_axes = 1;
  lab_->group().node().publish(lcm::channels::signed_gateway_command("can0"), coordinator.sign(enable, wall_time_us()));
  motionlcm::gateway_command2_t enable2{};
  lcm::copy_command_common(enable, enable2);
  enable2.command_id = 900102;
  lab_->group().node().publish(lcm::channels::gateway_command2("can0"), enable2);
  EXPECT_TRUE(lab_->client().wait_until(
      [&] {
        return lab_->has_event(motionlcm::event_t::SECURITY, "",
                               "unsigned command 900102 (request 0) refused: security is enforced");
      },
      seconds(3)));
  enable2.command_id = 900103;
  enable2.utime = wall_time_us();
  lab_->group().node().publish(lcm::channels::signed_gateway_command("can0"),
                               coordinator.sign(enable2, wall_time_us()));
  EXPECT_TRUE(
      lab_->client().wait_until([&] { return replied.contains(900101) && replied.contains(900103); }, seconds(3)));
  EXPECT_EQ(replied[900101], st(motionlcm::gateway_reply_t::DONE));
  EXPECT_EQ(replied[900103], st(motionlcm::gateway_reply_t::DONE));
  EXPECT_FALSE(replied.contains(900102));
  expect_nothing_moved();
}

}  // namespace
}  // namespace motion::testing
