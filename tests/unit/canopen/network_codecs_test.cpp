// CiA 301 network codecs: COB-IDs (§7.3.3), NMT (§7.2.8.3.1, M-01, D-12..D-15), heartbeat and
// boot-up (§7.2.8.3.2, D-17, D-18), SYNC (§7.2.5, D-16), EMCY (§7.2.7, D-45, D-46); every decoder
// refuses short frames and trailing bytes.
#include <gtest/gtest.h>

#include <array>
#include <cstdint>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/canopen/emcy.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/sync.hpp"

namespace motion::canopen {
namespace {

using test::frame;
using test::payload;

// --- COB-IDs: the predefined connection set (CiA 301 §7.3.3; UC57 manual §4.1.2), node 1 column ---

TEST(CobId, PredefinedConnectionSetForNodeOne) {
  EXPECT_EQ(emcy_cob_id(1), 0x081u);
  EXPECT_EQ(tpdo_cob_id(1, 1), 0x181u);
  EXPECT_EQ(rpdo_cob_id(1, 1), 0x201u);
  EXPECT_EQ(tpdo_cob_id(2, 1), 0x281u);
  EXPECT_EQ(rpdo_cob_id(2, 1), 0x301u);
  EXPECT_EQ(tpdo_cob_id(3, 1), 0x381u);
  EXPECT_EQ(rpdo_cob_id(3, 1), 0x401u);
  EXPECT_EQ(tpdo_cob_id(4, 1), 0x481u);
  EXPECT_EQ(rpdo_cob_id(4, 1), 0x501u);
  EXPECT_EQ(sdo_response_cob_id(1), 0x581u);
  EXPECT_EQ(sdo_request_cob_id(1), 0x601u);
  EXPECT_EQ(heartbeat_cob_id(1), 0x701u);
  EXPECT_EQ(heartbeat_cob_id(127), 0x77Fu);
  EXPECT_EQ(rpdo_cob_id(1, 0x12), 0x212u);  // node 18 -> 212h (CiA 301 §7.3.3)
}

TEST(CobId, ClassifiesEveryFunctionCode) {
  EXPECT_EQ(classify_cob_id(0x000), (CobIdInfo{MessageKind::kNmt, 0, 0}));
  EXPECT_EQ(classify_cob_id(0x080), (CobIdInfo{MessageKind::kSync, 0, 0}));
  EXPECT_EQ(classify_cob_id(0x100), (CobIdInfo{MessageKind::kTime, 0, 0}));
  EXPECT_EQ(classify_cob_id(0x081), (CobIdInfo{MessageKind::kEmcy, 1, 0}));
  EXPECT_EQ(classify_cob_id(0x0FF), (CobIdInfo{MessageKind::kEmcy, 127, 0}));
  for (std::uint8_t pdo = 1; pdo <= 4; ++pdo) {
    EXPECT_EQ(classify_cob_id(tpdo_cob_id(pdo, 5)), (CobIdInfo{MessageKind::kTpdo, 5, pdo}));
    EXPECT_EQ(classify_cob_id(rpdo_cob_id(pdo, 5)), (CobIdInfo{MessageKind::kRpdo, 5, pdo}));
  }
  EXPECT_EQ(classify_cob_id(0x581), (CobIdInfo{MessageKind::kSdoResponse, 1, 0}));
  EXPECT_EQ(classify_cob_id(0x601), (CobIdInfo{MessageKind::kSdoRequest, 1, 0}));
  EXPECT_EQ(classify_cob_id(0x701), (CobIdInfo{MessageKind::kHeartbeat, 1, 0}));
}

TEST(CobId, RejectsIdentifiersOutsideThePredefinedSet) {
  EXPECT_FALSE(classify_cob_id(0x001));  // NMT with a node part
  EXPECT_FALSE(classify_cob_id(0x101));  // TIME with a node part
  EXPECT_FALSE(classify_cob_id(0x180));  // TPDO1 of node 0
  EXPECT_FALSE(classify_cob_id(0x600));  // SDO of node 0
  EXPECT_FALSE(classify_cob_id(0x681));  // function code 1101b
  EXPECT_FALSE(classify_cob_id(0x7E5));  // LSS
  EXPECT_FALSE(classify_cob_id(0x800));  // beyond 11 bits
}

// --- NMT ---

struct NmtVector {
  const char* text;
  NmtRequest request;
};

TEST(Nmt, EncodesAndDecodesEverySpecFrame) {
  const std::vector<NmtVector> vectors = {
      {"000: 01 00", {NmtCommand::kStart, kAllNodes}},                // M-01, P-01, V-01, H-01, D-13
      {"00: 01 00", {NmtCommand::kStart, kAllNodes}},                 // as printed in the manual
      {"000: 01 01", {NmtCommand::kStart, 1}},                        // D-12, D-38
      {"000: 80 01", {NmtCommand::kEnterPreOperational, 1}},          // D-14, D-30
      {"000: 80 00", {NmtCommand::kEnterPreOperational, kAllNodes}},  // all nodes pre-operational before a remap
      {"000: 02 01", {NmtCommand::kStop, 1}},                         // D-15
      {"000: 81 01", {NmtCommand::kResetNode, 1}},
      {"000: 82 01", {NmtCommand::kResetCommunication, 1}},
      {"000: 02 00", {NmtCommand::kStop, kAllNodes}},
  };
  for (const auto& v : vectors) {
    SCOPED_TRACE(v.text);
    EXPECT_EQ(encode_nmt(v.request), frame(v.text));
    EXPECT_EQ(decode_nmt(payload(v.text)), v.request);
  }
}

TEST(Nmt, RejectsShortLongAndUnknownFrames) {
  EXPECT_FALSE(decode_nmt(payload("000: 01")));
  EXPECT_FALSE(decode_nmt(payload("000: 01 00 00")));
  EXPECT_FALSE(decode_nmt(payload("000:")));
  EXPECT_FALSE(decode_nmt(payload("000: 03 01")));  // no such command specifier
  EXPECT_FALSE(decode_nmt(payload("000: 01 80")));  // node-ID 128
}

// --- Heartbeat / boot-up ---

TEST(Heartbeat, BootUpAndStatesOfNodeOne) {
  EXPECT_EQ(encode_heartbeat(1, NmtState::kBootUp), frame("701: 00"));       // D-17
  EXPECT_EQ(encode_heartbeat(1, NmtState::kOperational), frame("701: 05"));  // D-18
  EXPECT_EQ(encode_heartbeat(1, NmtState::kPreOperational), frame("701: 7F"));
  EXPECT_EQ(encode_heartbeat(1, NmtState::kStopped), frame("701: 04"));
  EXPECT_EQ(decode_heartbeat(payload("701: 00")), NmtState::kBootUp);
  EXPECT_EQ(decode_heartbeat(payload("701: 05")), NmtState::kOperational);
  EXPECT_EQ(decode_heartbeat(payload("701: 7F")), NmtState::kPreOperational);
  EXPECT_EQ(decode_heartbeat(payload("701: 04")), NmtState::kStopped);
}

TEST(Heartbeat, RejectsShortLongToggledAndUnknownStates) {
  EXPECT_FALSE(decode_heartbeat(payload("701:")));
  EXPECT_FALSE(decode_heartbeat(payload("701: 05 00")));
  EXPECT_FALSE(decode_heartbeat(payload("701: 85")));  // node-guarding toggle bit
  EXPECT_FALSE(decode_heartbeat(payload("701: 01")));
}

// --- SYNC ---

TEST(Sync, PlainSyncHasNoData) {
  EXPECT_EQ(encode_sync({}), frame("080:"));  // D-16, the SYNC that starts a synchronized move
  EXPECT_EQ(decode_sync(payload("080:")), SyncMessage{});
}

TEST(Sync, CounterByteWhenConfigured) {
  EXPECT_EQ(encode_sync({std::uint8_t{7}}), frame("080: 07"));
  EXPECT_EQ(decode_sync(payload("080: F0")), SyncMessage{std::uint8_t{240}});
  EXPECT_FALSE(decode_sync(payload("080: 00")));     // counters start at 1
  EXPECT_FALSE(decode_sync(payload("080: F1")));     // above 240
  EXPECT_FALSE(decode_sync(payload("080: 01 00")));  // trailing byte
}

TEST(SyncProducer, FixedRateWithCounterAndSkipsMissedPeriods) {
  using namespace std::chrono_literals;
  std::vector<can::Frame> sent;
  SyncProducer producer([&](const can::Frame& f) { sent.push_back(f); }, {10ms, 3, kSyncCobId});
  const TimePoint t0 = TimePoint{} + 1h;
  EXPECT_EQ(producer.next_deadline(), kNever);
  EXPECT_EQ(producer.start(t0), t0 + 10ms);
  EXPECT_EQ(producer.process(t0 + 9ms), t0 + 10ms);
  EXPECT_TRUE(sent.empty());
  EXPECT_EQ(producer.process(t0 + 11ms), t0 + 20ms);  // late call: the grid does not shift
  EXPECT_EQ(producer.process(t0 + 20ms), t0 + 30ms);
  EXPECT_EQ(producer.process(t0 + 30ms), t0 + 40ms);
  EXPECT_EQ(producer.process(t0 + 40ms), t0 + 50ms);
  EXPECT_EQ(test::to_texts(sent), (std::vector<std::string>{"080: 01", "080: 02", "080: 03", "080: 01"}));
  // Three whole periods missed: one SYNC, no burst.
  EXPECT_EQ(producer.process(t0 + 85ms), t0 + 90ms);
  EXPECT_EQ(sent.size(), 5u);
  EXPECT_EQ(producer.skipped(), 3u);
  // trigger_now restarts the period.
  EXPECT_EQ(producer.trigger_now(t0 + 87ms), t0 + 97ms);
  EXPECT_EQ(producer.sent(), 6u);
  producer.stop();
  EXPECT_EQ(producer.process(t0 + 200ms), kNever);
}

// In loop mode a new period counts from the last SYNC; a deadline already past sends at once.
TEST(SyncProducer, ANewPeriodCountsFromTheLastSync) {
  using namespace std::chrono_literals;
  std::vector<can::Frame> sent;
  SyncProducer producer([&](const can::Frame& f) { sent.push_back(f); }, {10ms, 0, kSyncCobId});
  const TimePoint t0{};
  producer.start(t0);
  EXPECT_EQ(producer.process(t0 + 10ms), t0 + 20ms);
  producer.set_period(30ms, t0 + 12ms);
  EXPECT_EQ(producer.next_deadline(), t0 + 40ms);
  EXPECT_EQ(producer.process(t0 + 20ms), t0 + 40ms);
  EXPECT_EQ(sent.size(), 1U) << "no SYNC at the old period's deadline";
  EXPECT_EQ(producer.process(t0 + 40ms), t0 + 70ms);
  producer.set_period(10ms, t0 + 55ms);
  EXPECT_EQ(producer.next_deadline(), t0 + 55ms) << "40 + 10 is past: now";
  EXPECT_EQ(producer.process(t0 + 55ms), t0 + 65ms);
  EXPECT_EQ(sent.size(), 3U);
  EXPECT_EQ(producer.skipped(), 0U);
}

TEST(SyncProducer, AperiodicProducerOnlyTriggers) {
  std::vector<can::Frame> sent;
  SyncProducer producer([&](const can::Frame& f) { sent.push_back(f); }, {});
  const TimePoint t0{};
  EXPECT_EQ(producer.start(t0), kNever);
  EXPECT_EQ(producer.trigger_now(t0), kNever);
  ASSERT_EQ(sent.size(), 1u);
  EXPECT_EQ(sent[0], frame("080:"));
}

TEST(SyncProducer, RejectsReservedCounterOverflow) {
  EXPECT_THROW(SyncProducer({}, {Duration{}, 1, kSyncCobId}), std::invalid_argument);
  EXPECT_THROW(SyncProducer({}, {Duration{}, 241, kSyncCobId}), std::invalid_argument);
}

// --- EMCY ---

TEST(Emcy, OvercurrentAndErrorResetOfNodeOne) {
  const Emergency overcurrent{0x2310, 0x03, {0x01, 0x01, 0x00, 0x00, 0x00}};  // D-45
  EXPECT_EQ(encode_emcy(1, overcurrent), frame("081: 10 23 03 01 01 00 00 00"));
  EXPECT_EQ(decode_emcy(payload("081: 10 23 03 01 01 00 00 00")), overcurrent);
  EXPECT_EQ(encode_emcy(1, Emergency{}), frame("081: 00 00 00 00 00 00 00 00"));  // D-46
  EXPECT_EQ(decode_emcy(payload("081: 00 00 00 00 00 00 00 00")), Emergency{});
  EXPECT_TRUE(has(overcurrent.error_register, ErrorRegisterBit::kCurrent));
  EXPECT_FALSE(has(overcurrent.error_register, ErrorRegisterBit::kVoltage));
}

TEST(Emcy, RejectsShortAndLongFrames) {
  EXPECT_FALSE(decode_emcy(payload("081: 10 23 03 01 01 00 00")));
  EXPECT_FALSE(decode_emcy(payload("081:")));
  std::array<std::uint8_t, 9> nine{};
  EXPECT_FALSE(decode_emcy(nine));
}

TEST(Emcy, ClassifiesTheSpecSection54Codes) {
  EXPECT_EQ(classify_error_code(0x0000), EmcyErrorClass::kNoError);
  EXPECT_EQ(classify_error_code(0x1000), EmcyErrorClass::kGeneric);
  EXPECT_EQ(classify_error_code(0x2310), EmcyErrorClass::kCurrent);
  EXPECT_EQ(classify_error_code(0x3210), EmcyErrorClass::kVoltage);
  EXPECT_EQ(classify_error_code(0x3220), EmcyErrorClass::kVoltage);
  EXPECT_EQ(classify_error_code(0x4210), EmcyErrorClass::kTemperature);
  EXPECT_EQ(classify_error_code(0x5000), EmcyErrorClass::kHardware);
  EXPECT_EQ(classify_error_code(0x5530), EmcyErrorClass::kReserved);  // 55xxh is not 50xxh
  EXPECT_EQ(classify_error_code(0x6100), EmcyErrorClass::kSoftware);
  EXPECT_EQ(classify_error_code(0x8130), EmcyErrorClass::kCommunication);
  EXPECT_EQ(classify_error_code(0x8210), EmcyErrorClass::kProtocol);
  EXPECT_EQ(classify_error_code(0x8611), EmcyErrorClass::kMonitoring);
  EXPECT_EQ(classify_error_code(0x9000), EmcyErrorClass::kExternal);
  EXPECT_EQ(classify_error_code(0xF000), EmcyErrorClass::kAdditionalFunctions);
  EXPECT_EQ(classify_error_code(0xFF04), EmcyErrorClass::kDeviceSpecific);
}

TEST(EmcyConsumer, DeliversEventsAndTracksTheLastEmergency) {
  EmcyConsumer consumer;
  std::vector<EmcyEvent> events;
  consumer.on_event([&](const EmcyEvent& e) { events.push_back(e); });
  const TimePoint t{};
  EXPECT_TRUE(consumer.on_frame(frame("081: 10 23 03 01 01 00 00 00"), t));
  EXPECT_TRUE(consumer.on_frame(frame("081: 00 00 00 00 00 00 00 00"), t));
  ASSERT_EQ(events.size(), 2u);
  EXPECT_EQ(events[0].node, 1);
  EXPECT_EQ(events[0].error_class, EmcyErrorClass::kCurrent);
  EXPECT_FALSE(events[0].is_reset());
  EXPECT_TRUE(events[1].is_reset());
  EXPECT_EQ(consumer.last(1), Emergency{});
  EXPECT_FALSE(consumer.last(2));
  // Not EMCY: SYNC, a TPDO. A short EMCY is consumed but produces no event.
  EXPECT_FALSE(consumer.on_frame(frame("080:"), t));
  EXPECT_FALSE(consumer.on_frame(frame("181: 37 02 00 00 00 00 01"), t));
  EXPECT_TRUE(consumer.on_frame(frame("082: 10 23"), t));
  EXPECT_EQ(events.size(), 2u);
}

TEST(EmcyConsumer, NodeWithMovedEmcyCobId) {
  EmcyConsumer consumer;
  std::vector<NodeId> nodes;
  consumer.on_event([&](const EmcyEvent& e) { nodes.push_back(e.node); });
  consumer.set_cob_id(3, 0x0F0);
  EXPECT_FALSE(consumer.on_frame(frame("083: 00 00 00 00 00 00 00 00"), {}));  // its default no longer counts
  EXPECT_TRUE(consumer.on_frame(frame("0F0: 00 00 00 00 00 00 00 00"), {}));
  EXPECT_EQ(nodes, (std::vector<NodeId>{3}));
}

}  // namespace
}  // namespace motion::canopen
