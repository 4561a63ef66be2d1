// UiMessageTransport over a real pty: what it writes is byte for byte the UIMessage
// vectors derived from manual §2.6 and Appendix-1 (both CRC coverages), what the gateway side
// writes comes out as the drives' CAN frames, garbage and corrupt frames are skipped and counted,
// frames a UIMessage cannot carry are refused, and a hung-up port is reported and opened again.
#include "motion/uimessage/uimessage_transport.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "motion/gateway/can_transport_factory.hpp"
#include "motion/uim342/identifier.hpp"
#include "pty_peer.hpp"

namespace motion::uimessage {
namespace {

using test::hex;
using test::PtyPeer;
using test::receive_frames;

can::Frame frame(const char* cansend) {
  const auto f = can::parse_cansend(cansend);
  EXPECT_TRUE(f.has_value()) << cansend;
  return f.value_or(can::Frame{});
}

// UIMessages (§2.6, CRC per Appendix-1; not printed in the manual): the host's instructions to
// node 5 (and one to global 0), with the CAN frame that carries each one from master 4
// (§2.5: 0x04280000 | CW to node 5).
struct Vector {
  const char* can;
  const char* variant_a;  // CRC over SM..d8 (manual)
  const char* variant_b;  // CRC over ID..d8
};
constexpr Vector kInstructions[] = {
    {"04280095#01", "AA 05 95 01 01 00 00 00 00 00 00 00 00 27 D7 CC",
     "AA 05 95 01 01 00 00 00 00 00 00 00 00 D8 95 CC"},
    {"0428008B#", "AA 05 8B 00 00 00 00 00 00 00 00 00 00 1B AA CC", "AA 05 8B 00 00 00 00 00 00 00 00 00 00 E4 E8 CC"},
    {"04280096#", "AA 05 96 00 00 00 00 00 00 00 00 00 00 74 C6 CC", "AA 05 96 00 00 00 00 00 00 00 00 00 00 8B 84 CC"},
    {"04000016#", "AA 00 16 00 00 00 00 00 00 00 00 00 00 D1 08 CC", "AA 00 16 00 00 00 00 00 00 00 00 00 00 2E 4A CC"},
    {"0428009D#18FCFFFF", "AA 05 9D 04 18 FC FF FF 00 00 00 00 00 AE 26 CC",
     "AA 05 9D 04 18 FC FF FF 00 00 00 00 00 51 64 CC"},
    {"04280081#0502", "AA 05 81 02 05 02 00 00 00 00 00 00 00 25 31 CC",
     "AA 05 81 02 05 02 00 00 00 00 00 00 00 DA 73 CC"},
    {"04280091#00", "AA 05 91 01 00 00 00 00 00 00 00 00 00 3F 77 CC",
     "AA 05 91 01 00 00 00 00 00 00 00 00 00 C0 35 CC"},
};
// Derived "MO ACK from node 5 (ON)" (§2.6, Appendix-1 CRC); the drive's frame to master 4 is
// 0x05200000 | CW (§2.5).
constexpr const char* kMoAckA = "AA 05 15 01 01 00 00 00 00 00 00 00 00 8E 15 CC";
constexpr const char* kMoAckB = "AA 05 15 01 01 00 00 00 00 00 00 00 00 71 57 CC";
constexpr const char* kMoAckCan = "05200015#01";

class UiMessageTransportTest : public ::testing::Test {
 protected:
  std::unique_ptr<UiMessageTransport> open(UiMessageOptions options = {}) {
    std::error_code error;
    auto transport = UiMessageTransport::open(peer->link(), serial::SerialSettings{}, options, error);
    EXPECT_TRUE(transport != nullptr) << error.message();
    if (transport) {
      transport->on_bus_event([this](const can::BusEvent& e) { events.push_back(e); });
    }
    return transport;
  }

  test::TempDir dir;
  std::unique_ptr<PtyPeer> peer = std::make_unique<PtyPeer>(dir.file("gateway.tty"));
  std::vector<can::BusEvent> events;
};

TEST_F(UiMessageTransportTest, SendWritesTheSpecVectorsInBothCrcCoverages) {
  for (const auto coverage : {uim342::CrcCoverage::kStartToAux, uim342::CrcCoverage::kIdToAux}) {
    UiMessageOptions options;
    options.crc = coverage;
    auto transport = open(options);
    ASSERT_TRUE(transport);
    EXPECT_EQ(transport->name(), "uimessage:" + peer->link());
    EXPECT_EQ(transport->state(), can::BusState::kErrorActive);
    for (const auto& v : kInstructions) {
      SCOPED_TRACE(v.can);
      ASSERT_FALSE(transport->send(frame(v.can)));
      EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)),
                coverage == uim342::CrcCoverage::kStartToAux ? v.variant_a : v.variant_b);
    }
    const auto stats = transport->statistics();
    EXPECT_EQ(stats.tx_frames, std::size(kInstructions));
    EXPECT_EQ(stats.tx_bytes, 1u + 0 + 0 + 0 + 4 + 2 + 1);
    EXPECT_EQ(stats.tx_dropped, 0u);
  }
}

TEST_F(UiMessageTransportTest, ReceivedUiMessagesBecomeTheDrivesFramesWhicheverTheCoverage) {
  auto transport = open();
  ASSERT_TRUE(transport);
  peer->write(kMoAckA);
  peer->write(kMoAckB);
  peer->write("AD 05 15 01 01 00 00 00 00 00 00 00 00 00 00 CC");  // SM 0xAD: no CRC
  // ID 128 does not fit the 7-bit producer field: well-formed, but no CAN frame (counted).
  peer->write("AD 80 15 01 00 00 00 00 00 00 00 00 00 00 00 CC");
  // Node 100 (ID bits 6..5 in the EID part): producer 100 -> master 4 is 0x04230000 | CW (derived
  // from §2.5).
  peer->write("AD 64 15 01 00 00 00 00 00 00 00 00 00 00 00 CC");
  const auto frames = receive_frames(*transport, 4);
  ASSERT_EQ(frames.size(), 4u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(can::to_cansend(frames[i]), kMoAckCan);
    EXPECT_GT(frames[i].timestamp_us, 0);
  }
  EXPECT_EQ(can::to_cansend(frames[3]), "04230015#00");
  const auto counters = transport->counters();
  EXPECT_EQ(counters.crc_start_to_aux, 1u);
  EXPECT_EQ(counters.crc_id_to_aux, 1u);
  EXPECT_EQ(counters.without_crc, 3u);
  EXPECT_EQ(counters.unconvertible, 1u);
  const auto stats = transport->statistics();
  EXPECT_EQ(stats.rx_frames, 4u);
  EXPECT_EQ(stats.rx_bytes, 4u);
  EXPECT_EQ(stats.errors, 1u);
}

TEST_F(UiMessageTransportTest, StrictAcceptanceCountsTheOtherCoverageAsCrcErrors) {
  UiMessageOptions options;
  options.crc = uim342::CrcCoverage::kIdToAux;
  options.accept = uim342::CrcAcceptance::kIdToAux;
  auto transport = open(options);
  ASSERT_TRUE(transport);
  peer->write(kMoAckA);  // the manual's coverage: refused here
  peer->write(kMoAckB);
  const auto frames = receive_frames(*transport, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(can::to_cansend(frames[0]), kMoAckCan);
  EXPECT_EQ(transport->counters().stream.crc_errors, 1u);
  EXPECT_EQ(transport->statistics().errors, 1u);
  EXPECT_EQ(transport->counters().crc_id_to_aux, 1u);
}

// uimessage_crc: detect against a gateway that checks ID..d8 and drops everything else: the
// first four frames (13 bytes, the manual's) go unanswered, the fifth goes out over 12 bytes, the
// gateway's answer (over 12) settles it, it is reported once, and everything after uses 12.
TEST_F(UiMessageTransportTest, DetectionSwitchesToTheCoverageOfTheGatewaysReplies) {
  UiMessageOptions options;
  options.detect_crc = true;
  auto transport = open(options);
  ASSERT_TRUE(transport);
  std::vector<std::string> reports;
  transport->on_crc_detected([&](const std::string& text) { reports.push_back(text); });
  EXPECT_NE(transport->crc_status().find("not known yet"), std::string::npos) << transport->crc_status();
  for (int i = 0; i < 4; ++i) {
    ASSERT_FALSE(transport->send(frame(kInstructions[0].can)));
    EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_a) << i;  // dropped by the gateway
  }
  ASSERT_FALSE(transport->send(frame(kInstructions[0].can)));
  EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_b) << "no switch after 4 unanswered";
  peer->write(kMoAckB);  // the gateway took it and the drive answered
  ASSERT_EQ(receive_frames(*transport, 1).size(), 1u);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_NE(reports[0].find("ID..d8 (12 bytes)"), std::string::npos) << reports[0];
  EXPECT_EQ(transport->crc_status(), "ID..d8 (12 bytes), detected from the gateway's frames");
  for (int i = 0; i < 6; ++i) {  // silence no longer changes anything
    ASSERT_FALSE(transport->send(frame(kInstructions[1].can)));
    EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[1].variant_b) << i;
  }
  peer->write(kMoAckB);
  ASSERT_EQ(receive_frames(*transport, 1).size(), 1u);
  EXPECT_EQ(reports.size(), 1u) << "reported again without news";
  EXPECT_EQ(transport->counters().crc_blind_switches, 1u);
}

// A configured coverage is trusted: no switch however many frames go unanswered.
TEST_F(UiMessageTransportTest, AConfiguredCoverageIsNeverSwitched) {
  auto transport = open();  // detect_crc false: the configured SM..d8
  ASSERT_TRUE(transport);
  for (int i = 0; i < 10; ++i) {
    ASSERT_FALSE(transport->send(frame(kInstructions[0].can)));
    EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_a) << i;
  }
  EXPECT_EQ(transport->crc_status(), "SM..d8 (13 bytes), configured (uimessage_crc)");
}

TEST_F(UiMessageTransportTest, ResynchronizesAfterGarbageAndTornFrames) {
  auto transport = open();
  ASSERT_TRUE(transport);
  // Line noise with false starts: an SM without its EM 15 bytes on, a lone EM.
  const auto garbage = test::hex_bytes("00 FF AA 12 CC AD 34 56");
  peer->write(garbage);
  // A frame torn over three writes: nothing comes out until it is complete.
  const auto ack = test::hex_bytes(kMoAckA);
  peer->write(std::span(ack).first(3));
  ASSERT_TRUE(test::wait_readable(transport->fd()));
  EXPECT_FALSE(transport->receive().has_value());
  peer->write(std::span(ack).subspan(3, 10));
  peer->write(std::span(ack).subspan(13));
  const auto frames = receive_frames(*transport, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(can::to_cansend(frames[0]), kMoAckCan);
  const auto counters = transport->counters();
  EXPECT_EQ(counters.stream.discarded_bytes, garbage.size());
  EXPECT_EQ(counters.stream.crc_errors, 0u);
  EXPECT_EQ(transport->statistics().rx_frames, 1u);
}

TEST_F(UiMessageTransportTest, CrcCorruptFrameIsCountedAndTheNextOneReceived) {
  auto transport = open();
  ASSERT_TRUE(transport);
  auto corrupt = test::hex_bytes(kMoAckA);
  corrupt[4] = 0x00;  // d0 flipped on the line: MO=0 must not be delivered
  peer->write(corrupt);
  peer->write(kMoAckB);
  const auto frames = receive_frames(*transport, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(can::to_cansend(frames[0]), kMoAckCan);
  EXPECT_EQ(transport->counters().stream.crc_errors, 1u);
  EXPECT_EQ(transport->statistics().errors, 1u);
  EXPECT_EQ(transport->statistics().rx_frames, 1u);
}

TEST_F(UiMessageTransportTest, RefusesFramesAUiMessageCannotCarry) {
  auto transport = open();
  ASSERT_TRUE(transport);
  const auto standard = transport->send(frame("123#DEADBEEF"));
  EXPECT_EQ(standard, make_error_code(UiMessageErrc::kStandardFrame));
  EXPECT_NE(standard.message().find("11-bit CAN frame"), std::string::npos) << standard.message();
  EXPECT_NE(standard.message().find("29-bit"), std::string::npos) << standard.message();
  EXPECT_EQ(transport->send(frame("04280095#R")), make_error_code(UiMessageErrc::kRemoteFrame));
  EXPECT_EQ(transport->send(frame("04280195#01")), make_error_code(UiMessageErrc::kNotSimpleCan));  // bit 8 reserved
  const auto from_node_6 = *uim342::encode_can_id({6, 5, 0x95});
  EXPECT_EQ(transport->send(*can::Frame::make(from_node_6, true, std::vector<std::uint8_t>{1})),
            make_error_code(UiMessageErrc::kForeignProducer));
  EXPECT_EQ(transport->statistics().tx_dropped, 4u);
  EXPECT_EQ(transport->statistics().tx_frames, 0u);
  // Nothing of them reached the line: the next bytes are the next good frame's.
  ASSERT_FALSE(transport->send(frame(kInstructions[0].can)));
  EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_a);
}

TEST_F(UiMessageTransportTest, OwnEchoConfirmsWrittenFramesThroughTheFd) {
  auto transport = open();
  ASSERT_TRUE(transport);
  ASSERT_FALSE(transport->set_own_echo(true));
  ASSERT_FALSE(transport->send(frame("04280095#01")));
  const auto echoed = receive_frames(*transport, 1);
  ASSERT_EQ(echoed.size(), 1u);
  EXPECT_EQ(can::to_cansend(echoed[0]), "04280095#01");
  EXPECT_FALSE(transport->receive().has_value());
  // Filters apply to echoes and received frames alike.
  ASSERT_FALSE(transport->set_filters({can::Filter{0x05200000, 0x1FFFFF00, true, true}}));
  ASSERT_FALSE(transport->send(frame("04280096#")));
  peer->write(kMoAckA);
  const auto filtered = receive_frames(*transport, 1);
  ASSERT_EQ(filtered.size(), 1u);
  EXPECT_EQ(can::to_cansend(filtered[0]), kMoAckCan);
}

TEST_F(UiMessageTransportTest, HungUpPortIsReportedAndOpenedAgainOnTheNextSend) {
  UiMessageOptions options;
  options.reopen_interval = std::chrono::milliseconds(0);
  auto transport = open(options);
  ASSERT_TRUE(transport);
  const int fd = transport->fd();
  peer.reset();  // the adapter is unplugged
  ASSERT_TRUE(test::wait_readable(fd));
  EXPECT_FALSE(transport->receive().has_value());
  EXPECT_EQ(transport->state(), can::BusState::kDisconnected);
  ASSERT_EQ(events.size(), 1u);
  EXPECT_EQ(events[0].state, can::BusState::kDisconnected);
  EXPECT_NE(events[0].text.find("uimessage:"), std::string::npos) << events[0].text;
  // Still gone: sends fail at once, nothing crashes.
  EXPECT_EQ(transport->send(frame("04280095#01")), make_error_code(UiMessageErrc::kDisconnected));
  EXPECT_EQ(transport->fd(), fd);

  peer = std::make_unique<PtyPeer>(dir.file("gateway.tty"));  // plugged in again
  ASSERT_FALSE(transport->send(frame("04280095#01")));
  EXPECT_EQ(transport->state(), can::BusState::kErrorActive);
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[1].state, can::BusState::kErrorActive);
  EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_a);
  peer->write(kMoAckA);
  const auto frames = receive_frames(*transport, 1);
  ASSERT_EQ(frames.size(), 1u);
  EXPECT_EQ(transport->fd(), fd);
  EXPECT_EQ(transport->counters().disconnects, 1u);
  EXPECT_EQ(transport->counters().reopens, 1u);
  EXPECT_EQ(transport->statistics().tx_dropped, 1u);
}

// The configuration path: a uimessage: bus opens this transport with its baud and CRC keys.
TEST_F(UiMessageTransportTest, FactoryOpensAUimessageBusWithItsConfiguredCrc) {
  const std::string yaml = "buses:\n  - {name: gw, transport: \"uimessage:" + peer->link() +
                           "\", baud: 57600, uimessage_crc: id_to_aux, uimessage_crc_strict: true}\n"
                           "  - {name: gone, transport: \"uimessage:" +
                           dir.file("missing.tty") + "\"}\n";
  const auto loaded = config::load_string(yaml, "gw.yaml");
  ASSERT_TRUE(loaded.ok()) << loaded.error_text();
  const auto& config = *loaded.config;
  std::error_code error;
  auto transport = gateway::open_can_transport(config, config.buses[0], "test", error);
  ASSERT_TRUE(transport) << error.message();
  EXPECT_EQ(transport->name(), "uimessage:" + peer->link());
  ASSERT_FALSE(transport->send(frame(kInstructions[0].can)));
  EXPECT_EQ(hex(peer->read(uim342::kUiMessageSize)), kInstructions[0].variant_b);
  peer->write(kMoAckA);  // strict: the other coverage is a CRC error
  peer->write(kMoAckB);
  EXPECT_EQ(receive_frames(*transport, 1).size(), 1u);
  EXPECT_EQ(transport->statistics().errors, 1u);

  EXPECT_FALSE(gateway::open_can_transport(config, config.buses[1], "test", error));
  EXPECT_EQ(error, std::errc::no_such_file_or_directory);
  const auto message = gateway::open_error_message(config, config.buses[1], error);
  EXPECT_NE(message.find("bus gone (uimessage:"), std::string::npos) << message;
  EXPECT_NE(message.find("cannot open serial port"), std::string::npos) << message;
  EXPECT_NE(message.find("plugged in"), std::string::npos) << message;
}

}  // namespace
}  // namespace motion::uimessage
