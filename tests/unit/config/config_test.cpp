#include "motion/config/config.hpp"
#include "motion/config/sim_variants.hpp"

#include <gtest/gtest.h>

#include <algorithm>

#include <cstdlib>
#include <string>

namespace motion::config {
namespace {

// A minimal valid file; each test breaks one thing in it.
const std::string kValid = R"(lcm:
  url: "udpm://239.255.76.67:7667?ttl=0"
buses:
  - name: can0
    transport: simcan:can0
    bitrate: 500000
  - name: rs485
    transport: simserial:rs485
    baud: 19200
drives:
  - {name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}
  - {name: yd, family: uim342, bus: can0, node_id: 6, group_id: 20}
  - {name: ad, family: uc57, bus: can0, node_id: 5}
  - {name: cd, family: adam-modbus, bus: rs485, node_id: 1}
axes:
  - name: x
    drive: xd
    steps_per_unit: 640
    limits: {min: 0, max: 100, velocity: 10, acceleration: 100}
)";

std::string replace(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << "test bug: '" << from << "' not in the base file";
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

// Loads `text` and expects exactly one error at `line` with `key` and `reason_part`.
void expect_single_error(const std::string& text, int line, const std::string& key, const std::string& reason_part) {
  const auto result = load_string(text, "lab.yaml");
  ASSERT_FALSE(result.ok()) << "accepted:\n" << text;
  ASSERT_EQ(result.errors.size(), 1u) << result.error_text();
  const auto& e = result.errors[0];
  EXPECT_EQ(e.where.file, "lab.yaml");
  EXPECT_EQ(e.where.line, line) << e.message();
  EXPECT_EQ(e.key, key) << e.message();
  EXPECT_NE(e.reason.find(reason_part), std::string::npos) << e.message();
  EXPECT_EQ(e.message().rfind("lab.yaml:" + std::to_string(line) + ":", 0), 0u) << e.message();
}

TEST(Config, ValidFileLoadsWithTypedValues) {
  const auto result = load_string(kValid, "lab.yaml");
  ASSERT_TRUE(result.ok()) << result.error_text();
  const Config& c = *result.config;
  ASSERT_EQ(c.buses.size(), 2u);
  EXPECT_EQ(c.buses[0].kind, TransportKind::kSimCan);
  EXPECT_EQ(c.buses[0].target, "can0");
  EXPECT_EQ(c.buses[1].baud, 19200);
  EXPECT_EQ(c.lcm.channel_prefix, "MOTION_");
  ASSERT_NE(c.find_drive("xd"), nullptr);
  EXPECT_EQ(c.find_drive("xd")->group_id, 20);
  EXPECT_EQ(c.find_drive("ad")->family, Family::kUc57);
  EXPECT_DOUBLE_EQ(c.find_axis("x")->steps_per_unit, 640);
  EXPECT_EQ(c.axes_on_bus("can0").size(), 1u);
  EXPECT_TRUE(c.axes_on_bus("rs485").empty());
}

TEST(Config, ShippedFilesAreValid) {
  const char* src = std::getenv("MOTION_SOURCE_DIR");
  ASSERT_NE(src, nullptr);
  for (const char* file : {"/config/sim-lab.yaml", "/config/examples/hardware.yaml"}) {
    const auto result = load_file(std::string(src) + file);
    EXPECT_TRUE(result.ok()) << file << ":\n" << result.error_text();
  }
  // The simulated lab has what the demo needs: 3 UIM342 (two in one group), 2 UC57, 1 Adam, 1 UIM242.
  const auto lab = load_file(std::string(src) + "/config/sim-lab.yaml");
  ASSERT_TRUE(lab.ok());
  int counts[4] = {};
  int grouped = 0;
  for (const auto& d : lab.config->drives) {
    ++counts[static_cast<int>(d.family)];
    grouped += d.group_id != 0;
  }
  EXPECT_EQ(counts[static_cast<int>(Family::kUim342)], 3);
  EXPECT_EQ(counts[static_cast<int>(Family::kUc57)], 2);
  EXPECT_EQ(counts[static_cast<int>(Family::kAdamModbus)], 1);
  EXPECT_EQ(counts[static_cast<int>(Family::kUim242)], 1);
  EXPECT_EQ(grouped, 2);
}

TEST(Config, SecurityIsOffByDefaultAndItsPathsAreFromTheFilesFolder) {
  const auto plain = load_string(kValid, "/etc/motionbus/lab.yaml");
  ASSERT_TRUE(plain.ok()) << plain.error_text();
  EXPECT_EQ(plain.config->security.mode, SecuritySettings::Mode::kOff);
  const auto secured =
      load_string(kValid +
                      "security:\n  mode: enforce\n  authorized_keys: keys/authorized_keys\n"
                      "  key: /etc/motionbus/keys/coordinator.key\n  coordinator_public_key: keys/coordinator.pub\n"
                      "  gateway_key: keys/gateway-{bus}.key\n  gateway_public_keys: keys/gateways.pub\n"
                      "  window_ms: 500\n",
                  "/etc/motionbus/lab.yaml");
  ASSERT_TRUE(secured.ok()) << secured.error_text();
  const auto& s = secured.config->security;
  EXPECT_EQ(s.mode, SecuritySettings::Mode::kEnforce);
  EXPECT_EQ(s.authorized_keys, "/etc/motionbus/keys/authorized_keys");
  EXPECT_EQ(s.key, "/etc/motionbus/keys/coordinator.key");
  EXPECT_EQ(s.coordinator_public_key, "/etc/motionbus/keys/coordinator.pub");
  EXPECT_EQ(s.gateway_key, "/etc/motionbus/keys/gateway-{bus}.key");
  EXPECT_EQ(s.window_ms, 500);
  EXPECT_STREQ(to_string(s.mode), "enforce");
  // Clients verify axis states with the gateway_public_keys file when it is set, else authorized_keys.
  EXPECT_EQ(s.gateway_public_keys, "/etc/motionbus/keys/gateways.pub");
  EXPECT_EQ(s.gateway_keys_file(), "/etc/motionbus/keys/gateways.pub");
  EXPECT_STREQ(s.gateway_keys_setting(), "security.gateway_public_keys");
  SecuritySettings without = s;
  without.gateway_public_keys.clear();
  EXPECT_EQ(without.gateway_keys_file(), "/etc/motionbus/keys/authorized_keys");
  EXPECT_STREQ(without.gateway_keys_setting(), "security.authorized_keys");
}

TEST(Config, BadSecuritySettingsNameTheKey) {
  expect_single_error(kValid + "security:\n  mode: strict\n", 21, "security.mode",
                      "'strict' is not a security mode (off, enforce)");
  const std::string keys = "  key: c.key\n  coordinator_public_key: c.pub\n  gateway_key: g.key\n";
  expect_single_error(kValid + "security:\n  mode: enforce\n" + keys, 21, "security.authorized_keys",
                      "required when security.mode is enforce");
  expect_single_error(kValid +
                          "security:\n  mode: enforce\n  authorized_keys: k\n  coordinator_public_key: c.pub\n"
                          "  gateway_key: g.key\n",
                      21, "security.key",
                      "required when security.mode is enforce (the coordinator signs its gateway commands)");
  expect_single_error(kValid + "security:\n  mode: enforce\n  authorized_keys: k\n  key: c.key\n  gateway_key: g.key\n",
                      21, "security.coordinator_public_key",
                      "required when security.mode is enforce (gateways verify the coordinator's commands)");
  expect_single_error(kValid +
                          "security:\n  mode: enforce\n  authorized_keys: k\n  key: c.key\n"
                          "  coordinator_public_key: c.pub\n",
                      21, "security.gateway_key",
                      "required when security.mode is enforce (gateways sign their axis states and replies");
  expect_single_error(kValid + "security:\n  authorized_keys: k\n  window_ms: 50\n", 22, "security.window_ms",
                      "50 is outside 100..600000 ms");
  expect_single_error(kValid + "security:\n  keys: k\n", 21, "security.keys", "unknown key");
}

// The adaptive trigger lead's bounds: trigger_lead_min_ms defaults to 5, is positive and not above
// trigger_lead_ms, and an error names its line.
TEST(Config, TriggerLeadMinimumIsCheckedAgainstTheMaximum) {
  const auto plain = load_string(kValid, "lab.yaml");
  ASSERT_TRUE(plain.ok()) << plain.error_text();
  EXPECT_EQ(plain.config->coordinator.trigger_lead_ms, 30);
  EXPECT_EQ(plain.config->coordinator.trigger_lead_min_ms, 5);
  const auto set = load_string(kValid + "coordinator:\n  trigger_lead_ms: 40\n  trigger_lead_min_ms: 3\n", "lab.yaml");
  ASSERT_TRUE(set.ok()) << set.error_text();
  EXPECT_EQ(set.config->coordinator.trigger_lead_min_ms, 3);
  expect_single_error(kValid + "coordinator:\n  trigger_lead_ms: 20\n  trigger_lead_min_ms: 25\n", 22,
                      "coordinator.trigger_lead_min_ms", "must not exceed trigger_lead_ms (20 ms)");
  expect_single_error(kValid + "coordinator:\n  trigger_lead_min_ms: 0\n", 21, "coordinator.trigger_lead_min_ms",
                      "must be greater than zero");
}

// simulation.group: who besides motion-sim's user may open the simulated buses' sockets and ptys.
TEST(Config, SimulationGroupGivesTheAccessOfSimulatedBuses) {
  const auto plain = load_string(kValid, "lab.yaml");
  ASSERT_TRUE(plain.ok()) << plain.error_text();
  std::string why;
  const auto owner_only = sim_file_access(*plain.config, &why);
  ASSERT_TRUE(owner_only.has_value());
  EXPECT_EQ(owner_only->mode(), 0600U);
  const auto grouped = load_string(kValid + "simulation:\n  group: root\n", "lab.yaml");
  ASSERT_TRUE(grouped.ok()) << grouped.error_text();
  const auto root = sim_file_access(*grouped.config, &why);
  ASSERT_TRUE(root.has_value()) << why;
  EXPECT_EQ(root->group, gid_t{0});
  EXPECT_EQ(root->mode(), 0660U);
  const auto unknown = load_string(kValid + "simulation:\n  group: no-such-group-here\n", "lab.yaml");
  ASSERT_TRUE(unknown.ok()) << unknown.error_text();  // a group of the simulator's machine, checked there
  EXPECT_FALSE(sim_file_access(*unknown.config, &why).has_value());
  EXPECT_EQ(why, "simulation.group: no group 'no-such-group-here' on this machine");
}

// simulation.serial_link: what motion-sim makes a simserial: line, a pty (default) or a socket.
TEST(Config, SimulatedSerialLinesArePtysUnlessSockets) {
  using Link = SimulationSettings::SerialLink;
  const auto plain = load_string(kValid, "lab.yaml");
  ASSERT_TRUE(plain.ok()) << plain.error_text();
  EXPECT_EQ(plain.config->simulation.serial_link, Link::kPty);
  for (const auto& [text, link] : {std::pair{"pty", Link::kPty}, std::pair{"socket", Link::kSocket}}) {
    const auto set = load_string(kValid + "simulation:\n  serial_link: " + text + "\n", "lab.yaml");
    ASSERT_TRUE(set.ok()) << set.error_text();
    EXPECT_EQ(set.config->simulation.serial_link, link) << text;
  }
  const int line = static_cast<int>(std::count(kValid.begin(), kValid.end(), '\n')) + 2;
  expect_single_error(kValid + "simulation:\n  serial_link: tcp\n", line, "simulation.serial_link",
                      "expected pty or socket, got 'tcp'");
}

TEST(Config, YamlSyntaxErrorHasLine) {
  const auto result = load_string("buses:\n  - name: [unclosed\n", "bad.yaml");
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.errors[0].key, "<yaml>");
  EXPECT_GE(result.errors[0].where.line, 2);
}

TEST(Config, MissingFileIsReported) {
  const auto result = load_file("/nonexistent/motion.yaml");
  ASSERT_FALSE(result.ok());
  EXPECT_NE(result.error_text().find("cannot open"), std::string::npos);
}

TEST(Config, UnknownKeyIsRefused) {
  expect_single_error(replace(kValid, "    bitrate: 500000\n", "    bitrate: 500000\n    bitrat: 1\n"), 7,
                      "buses[0].bitrat", "unknown key");
  expect_single_error(replace(kValid, "lcm:\n", "lcms:\n  x: 1\nlcm:\n"), 1, "lcms", "unknown key");
}

TEST(Config, WrongTypeIsRefused) {
  expect_single_error(replace(kValid, "bitrate: 500000", "bitrate: fast"), 6, "buses[0].bitrate",
                      "expected an integer");
  expect_single_error(replace(kValid, "steps_per_unit: 640", "steps_per_unit: [640]"), 18, "axes[0].steps_per_unit",
                      "expected a number");
  expect_single_error(replace(kValid, "node_id: 6,", "node_id: 6.5,"), 12, "drives[1].node_id", "expected an integer");
}

TEST(Config, NodeIdOutsideFamilyRangeIsRefused) {
  expect_single_error(replace(kValid, "node_id: 6,", "node_id: 4,"), 12, "drives[1].node_id",
                      "outside uim342's range 5..126");
  expect_single_error(replace(kValid, "bus: rs485, node_id: 1}", "bus: rs485, node_id: 65}"), 14, "drives[3].node_id",
                      "outside adam-modbus's range 1..64");
  expect_single_error(replace(kValid, "bus: can0, node_id: 5}", "bus: can0, node_id: 128}"), 13, "drives[2].node_id",
                      "outside uc57's range 1..127");
}

TEST(Config, DuplicateNodeIdOnOneBusIsRefused) {
  // The UC57 at node 5 does not collide with the UIM342 at node 5 (11-bit vs 29-bit frames)...
  ASSERT_TRUE(load_string(kValid, "lab.yaml").ok());
  // ...but two UIM342 at node 5 do.
  expect_single_error(replace(kValid, "node_id: 6,", "node_id: 5,"), 12, "drives[1].node_id",
                      "already used by drive 'xd'");
}

TEST(Config, GroupIdCollidingWithNodeIdIsRefused) {
  expect_single_error(replace(kValid, "node_id: 6, group_id: 20", "node_id: 6, group_id: 5"), 12, "drives[1].group_id",
                      "collides with the node id of drive 'xd'");
  expect_single_error(replace(kValid, "{name: cd, family: adam-modbus, bus: rs485, node_id: 1}",
                              "{name: cd, family: adam-modbus, bus: rs485, node_id: 1, group_id: 30}"),
                      14, "drives[3].group_id", "only for uim342");
}

TEST(Config, DuplicateNamesAreRefused) {
  expect_single_error(replace(kValid, "{name: yd,", "{name: xd,"), 12, "drives[1].name", "duplicate drive name 'xd'");
  std::string two_axes = kValid + R"(  - name: x
    drive: yd
    steps_per_unit: 640
    limits: {min: 0, max: 100, velocity: 10, acceleration: 100}
)";
  expect_single_error(two_axes, 20, "axes[1].name", "duplicate axis name 'x'");
  expect_single_error(replace(kValid, "drives:\n", "  - {name: can0, transport: socketcan:can1}\ndrives:\n"), 10,
                      "buses[2].name", "duplicate bus name 'can0'");
}

TEST(Config, DriveOnUndeclaredBusIsRefused) {
  expect_single_error(replace(kValid, "{name: yd, family: uim342, bus: can0", "{name: yd, family: uim342, bus: can9"),
                      12, "drives[1].bus", "undeclared bus 'can9'");
}

TEST(Config, FamilyOnWrongKindOfBusIsRefused) {
  expect_single_error(
      replace(kValid, "{name: cd, family: adam-modbus, bus: rs485", "{name: cd, family: adam-modbus, bus: can0"), 14,
      "drives[3].bus", "needs a serial bus");
}

// A UIROBOT UIM2513/UIM2533 serial gateway: a CAN bus for uim342 drives over a serial line.
TEST(Config, UiMessageGatewayBus) {
  const std::string gateway = replace(kValid, "transport: simcan:can0", "transport: uimessage:/dev/ttyUSB0");
  const std::string uim342_only = replace(gateway, "  - {name: ad, family: uc57, bus: can0, node_id: 5}\n", "");
  const auto defaults = load_string(uim342_only, "lab.yaml");
  ASSERT_TRUE(defaults.ok()) << defaults.error_text();
  const Bus& bus = defaults.config->buses[0];
  EXPECT_EQ(bus.kind, TransportKind::kUiMessage);
  EXPECT_TRUE(is_can(bus.kind));
  EXPECT_EQ(bus.target, "/dev/ttyUSB0");
  EXPECT_EQ(bus.baud, 115200);
  EXPECT_EQ(bus.uimessage_crc, UiMessageCrc::kDetect);  // follow the gateway's replies
  EXPECT_FALSE(bus.uimessage_crc_strict);
  // The coverage in bytes, as the manual counts it.
  for (const auto& [value, crc] : std::vector<std::pair<std::string, UiMessageCrc>>{
           {"13", UiMessageCrc::kStartToAux}, {"12", UiMessageCrc::kIdToAux}, {"detect", UiMessageCrc::kDetect}}) {
    const auto counted = load_string(replace(uim342_only, "bitrate: 500000", "uimessage_crc: " + value));
    ASSERT_TRUE(counted.ok()) << counted.error_text();
    EXPECT_EQ(counted.config->buses[0].uimessage_crc, crc) << value;
  }
  expect_single_error(replace(uim342_only, "bitrate: 500000", "uimessage_crc_strict: true"), 6,
                      "buses[0].uimessage_crc_strict", "needs a configured uimessage_crc");
  // The simulated gateway's CRC coverage is a variant of the bus.
  const auto variant = load_string(uim342_only + "simulation: {variants: {can0: {crc_bytes: 12}}}\n");
  ASSERT_TRUE(variant.ok()) << variant.error_text();
  EXPECT_EQ(sim_bus_variant(*variant.config, variant.config->buses[0], "crc_bytes"), "12");
  EXPECT_EQ(sim_bus_variant(*defaults.config, defaults.config->buses[0], "crc_bytes"), "13");  // the manual's text
  const auto eleven = load_string(uim342_only + "simulation: {variants: {can0: {crc_bytes: 11}}}\n");
  ASSERT_FALSE(eleven.ok());
  EXPECT_NE(eleven.error_text().find("simulation.variants.can0.crc_bytes: '11' is not one of 13, 12"),
            std::string::npos)
      << eleven.error_text();
  const auto not_uimessage = load_string(std::string(kValid) + "simulation: {variants: {can0: {crc_bytes: 12}}}\n");
  ASSERT_FALSE(not_uimessage.ok());
  EXPECT_NE(not_uimessage.error_text().find("only uimessage: buses have bus variants"), std::string::npos)
      << not_uimessage.error_text();

  const auto keyed =
      load_string(replace(uim342_only, "    bitrate: 500000\n",
                          "    baud: 57600\n    uimessage_crc: id_to_aux\n    uimessage_crc_strict: true\n"));
  ASSERT_TRUE(keyed.ok()) << keyed.error_text();
  EXPECT_EQ(keyed.config->buses[0].baud, 57600);
  EXPECT_EQ(keyed.config->buses[0].uimessage_crc, UiMessageCrc::kIdToAux);
  EXPECT_TRUE(keyed.config->buses[0].uimessage_crc_strict);

  expect_single_error(replace(uim342_only, "bitrate: 500000", "uimessage_crc: sm_to_d8"), 6, "buses[0].uimessage_crc",
                      "expected detect (follow the gateway's replies), start_to_aux or 13");
  expect_single_error(replace(uim342_only, "bitrate: 500000", "baud: 12345"), 6, "buses[0].baud",
                      "unsupported baud rate");
  expect_single_error(replace(kValid, "bitrate: 500000", "uimessage_crc: id_to_aux"), 6, "buses[0].uimessage_crc",
                      "only for uimessage: buses");
  // CANopen (11-bit) cannot travel as UIMessages.
  expect_single_error(gateway, 13, "drives[2].bus", "needs a CAN adapter (simcan: or socketcan:)");
}

TEST(Config, AxisOnUndeclaredDriveIsRefused) {
  expect_single_error(replace(kValid, "drive: xd", "drive: qd"), 17, "axes[0].drive", "undeclared drive 'qd'");
}

TEST(Config, NonPositiveScalesAndLimitsAreRefused) {
  expect_single_error(replace(kValid, "steps_per_unit: 640", "steps_per_unit: 0"), 18, "axes[0].steps_per_unit",
                      "greater than zero");
  expect_single_error(replace(kValid, "velocity: 10,", "velocity: -1,"), 19, "axes[0].limits.velocity",
                      "greater than zero");
  expect_single_error(replace(kValid, "acceleration: 100}", "acceleration: 0}"), 19, "axes[0].limits.acceleration",
                      "greater than zero");
  expect_single_error(replace(kValid, "{min: 0, max: 100,", "{min: 100, max: 0,"), 19, "axes[0].limits.max",
                      "greater than min");
}

TEST(Config, MissingRequiredKeyIsRefused) {
  expect_single_error(replace(kValid, "    steps_per_unit: 640\n", ""), 16, "axes[0].steps_per_unit",
                      "required key is missing");
}

// An integer bus key with a range, set on the first bus of kValid (line 7): `inside` loads into
// `field` of that bus while the second keeps `unset`; `edge` loads too; each of `outside` is refused
// with one error naming the key and containing its text.
void expect_bounded_bus_key(const std::string& key, int Bus::*field, int inside, int unset, int edge,
                            const std::vector<std::pair<int, std::string>>& outside) {
  const auto with = [&](int value) {
    return replace(kValid, "    bitrate: 500000\n",
                   "    bitrate: 500000\n    " + key + ": " + std::to_string(value) + "\n");
  };
  const auto result = load_string(with(inside), "lab.yaml");
  ASSERT_TRUE(result.ok()) << result.error_text();
  EXPECT_EQ(result.config->buses[0].*field, inside) << key;
  EXPECT_EQ(result.config->buses[1].*field, unset) << key << " unless asked";
  EXPECT_TRUE(load_string(with(edge), "lab.yaml").ok()) << key << ": " << edge;
  for (const auto& [value, text] : outside) expect_single_error(with(value), 7, "buses[0]." + key, text);
}

TEST(Config, RealtimePriorityIsOffOrASchedFifoPriority) {
  expect_bounded_bus_key("realtime_priority", &Bus::realtime_priority, 80, 0, 0,
                         {{100, "1..99, got 100"}, {-1, "1..99, got -1"}});
}

TEST(Config, TimerSpinIsOffOrUpTo500Microseconds) {
  expect_bounded_bus_key("timer_spin_us", &Bus::timer_spin_us, 80, 0, 500,
                         {{501, "0 (sleep to each deadline) .. 500"}, {-1, "got -1"}});
}

// The slice a gateway's loop asks for under normal scheduling: the kernel's default (0) unless
// configured, else the 100 us .. 100 ms the kernel takes.
TEST(Config, SchedSliceIsTheKernelsDefaultOr100MicrosecondsTo100Milliseconds) {
  expect_bounded_bus_key("sched_slice_us", &Bus::sched_slice_us, 500, 0, 100,
                         {{100001, "0 (the kernel's default slice) or 100..100000 us, got 100001"},
                          {99, "got 99"},
                          {1, "got 1"},
                          {-1, "got -1"}});
}

// How long a CPU may take to wake from idle while the gateway runs: the host's own setting unless
// asked (-1), else 0 (idle CPUs poll) .. 10 ms.
TEST(Config, CpuLatencyIsTheHostsOwnOrUpTo10Milliseconds) {
  expect_bounded_bus_key("cpu_latency_us", &Bus::cpu_latency_us, 0, -1, 10000,
                         {{10001, "0 (idle CPUs poll) .. 10000 us"}, {-1, "got -1"}});
}

// The time from a write to the first bit on the wire (a USB adapter): none unless configured, at
// most 20 ms, and below the least trigger lead (the trigger must reach the gateway before it hands
// its start over).
TEST(Config, EgressLatencyIsNoneOrUpTo20MillisecondsAndBelowTheLeastTriggerLead) {
  expect_bounded_bus_key(
      "egress_latency_us", &Bus::egress_latency_us, 350, 0, 4999,
      {{20001, "0 (frames reach the wire when handed over) .. 20000 us, got 20001"}, {-1, "got -1"}});
  const auto with = [](const std::string& latency, const std::string& least_lead) {
    return replace(kValid, "    bitrate: 500000\n", "    bitrate: 500000\n    egress_latency_us: " + latency + "\n") +
           "coordinator:\n  trigger_lead_ms: 30\n  trigger_lead_min_ms: " + least_lead + "\n";
  };
  EXPECT_TRUE(load_string(with("20000", "21"), "lab.yaml").ok());
  expect_single_error(with("5000", "5"), 7, "buses[0].egress_latency_us",
                      "must be below coordinator.trigger_lead_min_ms (5 ms)");
}

TEST(Config, KernelSyncIsOnForSocketCanBusesAndOnlyForThem) {
  const std::string socketcan = replace(kValid, "transport: simcan:can0", "transport: socketcan:can0");
  const auto plain = load_string(socketcan, "lab.yaml");
  ASSERT_TRUE(plain.ok()) << plain.error_text();
  EXPECT_TRUE(plain.config->buses[0].kernel_sync) << "the kernel sends the SYNC unless told not to";
  const auto with = [](const std::string& yaml, const std::string& value) {
    return replace(yaml, "    bitrate: 500000\n", "    bitrate: 500000\n    kernel_sync: " + value + "\n");
  };
  const auto off = load_string(with(socketcan, "false"), "lab.yaml");
  ASSERT_TRUE(off.ok()) << off.error_text();
  EXPECT_FALSE(off.config->buses[0].kernel_sync);
  expect_single_error(with(kValid, "true"), 7, "buses[0].kernel_sync", "only for socketcan: buses");
  expect_single_error(with(socketcan, "sometimes"), 7, "buses[0].kernel_sync", "");
}

TEST(Config, UnknownTransportIsRefused) {
  expect_single_error(replace(kValid, "transport: simcan:can0", "transport: pcan:can0"), 5, "buses[0].transport",
                      "unknown transport");
}

TEST(Config, DriveSetupIsValidatedPerFamily) {
  auto with_setup = [&](const std::string& setup) {
    return replace(kValid, "{name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20}",
                   "{name: xd, family: uim342, bus: can0, node_id: 5, group_id: 20, setup: " + setup + "}");
  };
  ASSERT_TRUE(
      load_string(with_setup("{micro_steps: 16, current_a: 2.0, closed_loop: true, acceleration_unit: time}")).ok());
  expect_single_error(with_setup("{micro_steps: 12}"), 11, "drives[0].setup.micro_steps",
                      "12 is out of range (1, 2, 4, 8, 16, 32, 64)");
  expect_single_error(with_setup("{current_a: 9.5}"), 11, "drives[0].setup.current_a", "out of range");
  expect_single_error(with_setup("{subdivision: 16}"), 11, "drives[0].setup.subdivision",
                      "unknown set-up key for uim342");
  expect_single_error(with_setup("{acceleration_unit: fast}"), 11, "drives[0].setup.acceleration_unit",
                      "not one of rate, time");
  expect_single_error(with_setup("{closed_loop: maybe}"), 11, "drives[0].setup.closed_loop", "true or false");
}

// tpdo_mode of a UC57: sync (default), staggered (every G-th SYNC in a slot of the node's own) or
// event; anything else names the three.
TEST(Config, Uc57TpdoModeIsOneOfSyncStaggeredEvent) {
  const auto with_mode = [&](const std::string& mode) {
    return replace(kValid, "{name: ad, family: uc57, bus: can0, node_id: 5}",
                   "{name: ad, family: uc57, bus: can0, node_id: 5, setup: {tpdo_mode: " + mode + "}}");
  };
  for (const auto* mode : {"sync", "staggered", "event"}) {
    const auto result = load_string(with_mode(mode), "lab.yaml");
    EXPECT_TRUE(result.ok()) << mode << ": " << result.error_text();
  }
  const auto bad = load_string(with_mode("stagger"), "lab.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error_text().find("drives[2].setup.tpdo_mode"), std::string::npos) << bad.error_text();
  EXPECT_NE(bad.error_text().find("'stagger' is not one of sync, staggered, event"), std::string::npos)
      << bad.error_text();
}

TEST(Config, EveryErrorIsReportedNotJustTheFirst) {
  std::string text = replace(kValid, "bitrate: 500000", "bitrate: 12345");
  text = replace(text, "node_id: 6,", "node_id: 200,");
  text = replace(text, "steps_per_unit: 640", "steps_per_unit: -2");
  const auto result = load_string(text, "lab.yaml");
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.errors.size(), 3u) << result.error_text();
}

// The homing method and input are checked against the axis's drive family, naming the key.
int line_of(const std::string& text, const std::string& part) {
  return 1 +
         static_cast<int>(std::count(text.begin(), text.begin() + static_cast<std::ptrdiff_t>(text.find(part)), '\n'));
}

TEST(Config, HomingMethodOrInputTheFamilyLacksIsRefusedNamingTheKey) {
  const std::string limits = "    limits: {min: 0, max: 100, velocity: 10, acceleration: 100}\n";
  const auto with = [&](const std::string& homing) {
    return replace(kValid, limits, limits + "    homing: " + homing + "\n");
  };
  const auto index = with("{method: index}");
  expect_single_error(index, line_of(index, "homing:"), "axes[0].homing.method",
                      "'index' is not a homing method of family uim342 (none, switch, current-position)");
  const auto in4 = with("{method: switch, input: 4}");
  expect_single_error(in4, line_of(in4, "homing:"), "axes[0].homing.input",
                      "input 4 is not an input of family uim342 (1..3: IN1..IN3)");
  const auto edge = with("{method: switch, edge: both}");
  expect_single_error(edge, line_of(edge, "homing:"), "axes[0].homing.edge", "expected falling or rising");
  const auto ok = load_string(with("{method: switch, input: 3, edge: rising, velocity: -2}"), "lab.yaml");
  ASSERT_TRUE(ok.ok()) << ok.error_text();
  EXPECT_EQ(ok.config->axes[0].homing.edge, HomingEdge::kRising);
  EXPECT_EQ(ok.config->axes[0].homing.input, 3);
}

TEST(Config, SimulatedHomeSwitchesArePositionsOrNone) {
  const auto ok = load_string(std::string(kValid) + "simulation: {home_switches: {xd: -3200, yd: none}}\n", "lab.yaml");
  ASSERT_TRUE(ok.ok()) << ok.error_text();
  EXPECT_EQ(ok.config->simulation.home_switches.at("xd"), -3200);
  EXPECT_FALSE(ok.config->simulation.home_switches.at("yd").has_value());
  const auto bad = load_string(std::string(kValid) + "simulation: {home_switches: {xd: left}}\n", "lab.yaml");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.error_text().find("simulation.home_switches.xd"), std::string::npos) << bad.error_text();
}

TEST(Config, SimulatedVariantsAreCheckedAgainstTheDrivesFamily) {
  const auto ok =
      load_string(std::string(kValid) + "simulation: {variants: {xd: {micro_steps_apply: immediately}}}\n", "lab.yaml");
  ASSERT_TRUE(ok.ok()) << ok.error_text();
  EXPECT_EQ(sim_variant(*ok.config, *ok.config->find_drive("xd"), "micro_steps_apply"), "immediately");
  EXPECT_EQ(sim_variant(*ok.config, *ok.config->find_drive("yd"), "micro_steps_apply"),
            "after_restart");  // the default
  for (const auto& [extra, reason] : std::vector<std::pair<std::string, std::string>>{
           {"simulation: {variants: {nobody: {micro_steps_apply: immediately}}}\n",
            "simulation.variants.nobody: names no drive (or bus)"},
           {"simulation: {variants: {xd: {reboot_ms: 5}}}\n",
            "'reboot_ms' is not a simulated variant of family uim342"},
           {"simulation: {variants: {xd: {micro_steps_apply: sometimes}}}\n",
            "'sometimes' is not one of after_restart, immediately"}}) {
    SCOPED_TRACE(extra);
    const auto bad = load_string(std::string(kValid) + extra, "lab.yaml");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error_text().find(reason), std::string::npos) << bad.error_text();
  }
}

TEST(Config, KeysThatAreListsOrMappingsAreErrorsNotCrashes) {
  // Found by the config_yaml fuzz target: a key that is itself a collection threw out of the loader.
  for (const std::string extra :
       {"simulation: {{a: 1}: 2}\n", "simulation: {home_switches: {[xd]: 1}}\n", "? [lcm]\n: 1\n"}) {
    SCOPED_TRACE(extra);
    const auto bad = load_string(std::string(kValid) + extra, "lab.yaml");
    ASSERT_FALSE(bad.ok());
    EXPECT_NE(bad.error_text().find("a key must be a plain name"), std::string::npos) << bad.error_text();
  }
}

}  // namespace
}  // namespace motion::config
