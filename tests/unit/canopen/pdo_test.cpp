// PDO payloads (default mappings of the UC57 manual's §5 comm. table, D-29, D-39..D-44), mapping
// entries (CiA 301 §7.5.2.36/38), the CiA 301 remap procedure through SDO (§7.5.2.35-38, D-30..D-38)
// and its execution by run_sdo_sequence.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/errors.hpp"
#include "motion/canopen/pdo.hpp"
#include "motion/canopen/pdo_config.hpp"
#include "motion/canopen/sdo_client.hpp"

namespace motion::canopen {
namespace {

using namespace std::chrono_literals;
using test::payload;
using Values = std::vector<std::uint64_t>;

// Default mappings (UC57 manual §5 comm. table).
const PdoMapping kRpdo1 = {{0x6040, 0, 16}, {0x60FF, 0, 32}, {0x6060, 0, 8}};
const PdoMapping kRpdo2 = {{0x607A, 0, 32}, {0x6081, 0, 32}};
const PdoMapping kTpdo1 = {{0x6041, 0, 16}, {0x60FD, 0, 32}, {0x6061, 0, 8}};
const PdoMapping kTpdo2 = {{0x6064, 0, 32}, {0x606C, 0, 32}};
// D-29: RPDO1 remapped as controlword + target position.
const PdoMapping kCustomRpdo1 = {{0x6040, 0, 16}, {0x607A, 0, 32}};

std::uint64_t as_raw(std::int64_t value) { return static_cast<std::uint64_t>(value); }

std::vector<std::uint8_t> bytes_of(const InlineBytes<kMaxPdoBytes>& b) { return {b.view().begin(), b.view().end()}; }

TEST(PdoMappingEntry, ManualAddressForm) {
  EXPECT_EQ(encode_mapping_entry({0x6081, 0, 32}), 0x60810020u);
  EXPECT_EQ(encode_mapping_entry({0x200E, 0, 16}), 0x200E0010u);
  EXPECT_EQ(encode_mapping_entry({0x6060, 0, 8}), 0x60600008u);
  EXPECT_EQ(decode_mapping_entry(0x60FD0020u), (PdoMappingEntry{0x60FD, 0, 32}));
  EXPECT_EQ(decode_mapping_entry(0x60990220u), (PdoMappingEntry{0x6099, 2, 32}));
}

struct PdoVector {
  const char* id;
  const char* frame;
  const PdoMapping* mapping;
  Values values;
};

TEST(PdoPayload, DefaultAndCustomMappingVectors) {
  const std::vector<PdoVector> vectors = {
      {"D-29", "201: 1F 00 10 27 00 00", &kCustomRpdo1, {0x001F, 10000}},
      {"D-39", "201: 1F 00 00 00 00 00 01", &kRpdo1, {0x001F, 0, 1}},
      {"D-40", "201: 0F 00 00 00 00 00 01", &kRpdo1, {0x000F, 0, 1}},
      {"D-41+", "201: 0F 00 3C 00 00 00 03", &kRpdo1, {0x000F, 60, 3}},
      {"D-41-", "201: 0F 00 C4 FF FF FF 03", &kRpdo1, {0x000F, 0xFFFFFFC4, 3}},
      {"D-42", "301: 10 27 00 00 3C 00 00 00", &kRpdo2, {10000, 60}},
      {"D-42b", "301: 80 F3 FF FF 78 00 00 00", &kRpdo2, {0xFFFFF380, 120}},
      {"D-43", "181: 37 02 00 00 00 00 01", &kTpdo1, {0x0237, 0, 1}},
      {"D-43b", "181: 27 A4 04 00 00 00 06", &kTpdo1, {0xA427, 4, 6}},
      {"D-44", "281: 10 27 00 00 3C 00 00 00", &kTpdo2, {10000, 60}},
  };
  for (const auto& v : vectors) {
    SCOPED_TRACE(v.id);
    EXPECT_EQ(unpack_pdo(*v.mapping, payload(v.frame)), v.values);
    const auto packed = pack_pdo(*v.mapping, v.values);
    ASSERT_TRUE(packed);
    EXPECT_EQ(bytes_of(*packed), payload(v.frame));
  }
}

TEST(PdoPayload, NegativeValuesPackAsTwosComplementAndSignExtendBack) {
  const Values values = {0x000F, as_raw(-60), 3};
  const auto packed = pack_pdo(kRpdo1, values);
  ASSERT_TRUE(packed);
  EXPECT_EQ(bytes_of(*packed), payload("201: 0F 00 C4 FF FF FF 03"));
  const auto raw = unpack_pdo(kRpdo1, packed->view());
  ASSERT_TRUE(raw);
  EXPECT_EQ(sign_extend((*raw)[1], 32), -60);
  EXPECT_EQ(sign_extend(0x80, 8), -128);
  EXPECT_EQ(sign_extend(0x7F, 8), 127);
}

TEST(PdoPayload, RejectsShortFramesTrailingBytesAndValuesThatDoNotFit) {
  EXPECT_FALSE(unpack_pdo(kRpdo1, payload("201: 0F 00 00 00 00 00")));        // 6 of 7 bytes
  EXPECT_FALSE(unpack_pdo(kRpdo1, payload("201: 0F 00 00 00 00 00 01 00")));  // trailing byte
  EXPECT_FALSE(unpack_pdo(kRpdo1, payload("201:")));
  EXPECT_FALSE(pack_pdo(kRpdo1, Values{0x1'0000, 0, 1}));         // 17 bits in 16
  EXPECT_FALSE(pack_pdo(kRpdo1, Values{0x0F, 0}));                // value count
  EXPECT_FALSE(pack_pdo(kRpdo1, Values{0x0F, 0, as_raw(-129)}));  // below I8
  EXPECT_TRUE(pack_pdo(kRpdo1, Values{0x0F, 0, as_raw(-128)}));
}

TEST(PdoPayload, MappingSizeLimits) {
  EXPECT_EQ(pdo_payload_size(kRpdo1), 7u);
  EXPECT_EQ(pdo_payload_size({}), 0u);  // sub00 = 0: an empty (disabled) PDO
  EXPECT_EQ(pdo_payload_size({{0x2000, 0, 1}, {0x2000, 0, 3}}), 1u);
  EXPECT_FALSE(pdo_payload_size({{0x607A, 0, 32}, {0x6081, 0, 32}, {0x6060, 0, 8}}));  // 72 bits
  EXPECT_FALSE(pdo_payload_size({{0x607A, 0, 0}}));
}

TEST(PdoPayload, BitPackedObjects) {
  const PdoMapping bits = {{0x2000, 1, 1}, {0x2000, 2, 3}, {0x2000, 3, 12}};
  const auto packed = pack_pdo(bits, Values{1, 5, 0xABC});
  ASSERT_TRUE(packed);
  EXPECT_EQ(bytes_of(*packed), (std::vector<std::uint8_t>{0xCB, 0xAB}));
  EXPECT_EQ(unpack_pdo(bits, packed->view()), (Values{1, 5, 0xABC}));
}

TEST(PdoParameterObjects, Indexes) {
  EXPECT_EQ(pdo_communication_index(PdoDirection::kReceive, 1), 0x1400);
  EXPECT_EQ(pdo_communication_index(PdoDirection::kTransmit, 4), 0x1803);
  EXPECT_EQ(pdo_mapping_index(PdoDirection::kReceive, 2), 0x1601);
  EXPECT_EQ(pdo_mapping_index(PdoDirection::kTransmit, 1), 0x1A00);
}

// The write frames the remap produces for D-30..D-38 (node 1, RPDO1 = 6040h + 607Ah, type 1).
TEST(PdoRemap, StepsAreTheSpecD31ToD37Frames) {
  PdoConfiguration config;
  config.direction = PdoDirection::kReceive;
  config.number = 1;
  config.cob_id = 0x201;
  config.transmission_type = 1;
  config.mapping = kCustomRpdo1;
  const auto steps = pdo_remap_steps(config, /*verify=*/false);
  ASSERT_TRUE(steps);
  std::vector<std::string> texts;
  for (const auto& step : *steps) {
    EXPECT_EQ(step.action, SdoStep::Action::kWrite);
    const auto data = *InlineBytes<kSdoExpeditedMax>::from(step.value);
    texts.push_back(test::to_text(
        sdo_request_frame(1, SdoInitiateDownloadRequest{SdoInitiateData::expedited_data(step.object, data)})));
  }
  EXPECT_EQ(texts, (std::vector<std::string>{
                       "601: 23 00 14 01 01 02 00 80",  // D-31 disable
                       "601: 2F 00 16 00 00 00 00 00",  // D-32
                       "601: 23 00 16 01 10 00 40 60",  // D-33
                       "601: 23 00 16 02 20 00 7A 60",  // D-34
                       "601: 2F 00 16 00 02 00 00 00",  // D-35
                       "601: 2F 00 14 02 01 00 00 00",  // D-36 synchronous
                       "601: 23 00 14 01 01 02 00 00",  // D-37 enable
                   }));
}

TEST(PdoRemap, VerifyStepsReadBackTheFinalValues) {
  PdoConfiguration config;
  config.direction = PdoDirection::kTransmit;
  config.number = 1;
  config.cob_id = 0x181;
  config.transmission_type = 1;
  config.inhibit_time = 10;
  config.event_timer = 100;
  config.mapping = kTpdo1;
  const auto steps = pdo_remap_steps(config);
  ASSERT_TRUE(steps);
  // 1 disable + 1 clear + 3 entries + 1 count + 3 comm + 1 enable = 10 writes; 8 verifies.
  ASSERT_EQ(steps->size(), 18u);
  const SdoStep& last = steps->back();
  EXPECT_EQ(last.action, SdoStep::Action::kVerify);
  EXPECT_EQ(last.object, (ObjectAddress{0x1800, 1}));
  EXPECT_EQ(last.compare_mask, ~std::uint64_t{kPdoCobIdNoRtr});  // devices may force bit 30 on
}

TEST(PdoRemap, RejectsInvalidConfigurations) {
  PdoConfiguration config;
  config.number = 0;
  EXPECT_FALSE(pdo_remap_steps(config));
  config.number = 513;
  EXPECT_FALSE(pdo_remap_steps(config));
  config.number = 1;
  config.mapping = {{0x607A, 0, 32}, {0x6081, 0, 32}, {0x6060, 0, 8}};
  EXPECT_FALSE(pdo_remap_steps(config));
}

// A scripted server: answers every SDO request of node 1 from a tiny object store.
class RemapThroughClient : public ::testing::Test {
 protected:
  RemapThroughClient() : client_([this](const can::Frame& f) { requests_.push_back(f); }, {100ms, 0, 64}) {}

  // Answers queued requests until the client goes quiet.
  void serve(TimePoint now) {
    for (int guard = 0; guard < 100; ++guard) {
      client_.process(now);
      if (requests_.empty()) return;
      const can::Frame request = requests_.front();
      requests_.erase(requests_.begin());
      const auto decoded = decode_sdo_request(request.payload());
      ASSERT_TRUE(decoded);
      if (const auto* write = std::get_if<SdoInitiateDownloadRequest>(&*decoded)) {
        if (refuse_ && write->object == *refuse_) {
          answer(SdoAbort{write->object, static_cast<std::uint32_t>(SdoAbortCode::kWriteOfReadOnly)}, now);
          continue;
        }
        store_[key(write->object)] = {write->data.view().begin(), write->data.view().end()};
        answer(SdoInitiateDownloadResponse{write->object}, now);
      } else if (const auto* read = std::get_if<SdoInitiateUploadRequest>(&*decoded)) {
        auto value = store_[key(read->object)];
        if (corrupt_ && read->object == *corrupt_) value[0] ^= 1;
        answer(SdoInitiateUploadResponse{SdoInitiateData::expedited_data(read->object, *InlineBytes<4>::from(value))},
               now);
      }
    }
    FAIL() << "server loop did not settle";
  }
  void answer(const SdoResponse& response, TimePoint now) { client_.on_frame(sdo_response_frame(1, response), now); }
  static std::uint32_t key(ObjectAddress a) { return (std::uint32_t{a.index} << 8) | a.subindex; }

  std::vector<can::Frame> requests_;
  SdoClient client_;
  std::map<std::uint32_t, std::vector<std::uint8_t>> store_;
  std::optional<ObjectAddress> refuse_;
  std::optional<ObjectAddress> corrupt_;
};

PdoConfiguration custom_rpdo1() {
  PdoConfiguration config;
  config.number = 1;
  config.cob_id = 0x201;
  config.transmission_type = 1;
  config.mapping = kCustomRpdo1;
  return config;
}

TEST_F(RemapThroughClient, SucceedsAndLeavesTheMappingInTheServer) {
  std::optional<SdoSequenceResult> result;
  configure_pdo(client_, 1, custom_rpdo1(), [&](const SdoSequenceResult& r) { result = r; });
  serve(TimePoint{});
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
  EXPECT_EQ(store_[key({0x1600, 0})], (std::vector<std::uint8_t>{2}));
  EXPECT_EQ(store_[key({0x1400, 1})], (std::vector<std::uint8_t>{0x01, 0x02, 0x00, 0x00}));
}

TEST_F(RemapThroughClient, StopsAtTheFirstAbortLikeARealUc57) {
  // The manual marks 1400h:01 RO (vector D-31: the device may answer 06010002h, CiA 301 §7.2.4.3.17).
  refuse_ = ObjectAddress{0x1400, 1};
  std::optional<SdoSequenceResult> result;
  configure_pdo(client_, 1, custom_rpdo1(), [&](const SdoSequenceResult& r) { result = r; });
  serve(TimePoint{});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kWriteOfReadOnly);
  EXPECT_EQ(result->failed_step, 0u);
}

TEST_F(RemapThroughClient, ReadBackMismatchIsReported) {
  corrupt_ = ObjectAddress{0x1600, 2};
  std::optional<SdoSequenceResult> result;
  configure_pdo(client_, 1, custom_rpdo1(), [&](const SdoSequenceResult& r) { result = r; });
  serve(TimePoint{});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, CanopenError::kReadBackMismatch);
}

TEST_F(RemapThroughClient, InvalidConfigurationCompletesAtOnce) {
  PdoConfiguration config = custom_rpdo1();
  config.number = 0;
  std::optional<SdoSequenceResult> result;
  configure_pdo(client_, 1, config, [&](const SdoSequenceResult& r) { result = r; });
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, CanopenError::kInvalidArgument);
  EXPECT_TRUE(requests_.empty());
}

}  // namespace
}  // namespace motion::canopen
