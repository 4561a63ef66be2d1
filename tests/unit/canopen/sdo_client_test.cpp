// The passive SDO client (sdo_client.hpp): expedited and segmented transfers frame by frame
// against the manual's and derived vectors, queueing per node, timeouts with retries, server
// aborts, protocol errors (toggle, command specifier, lengths, mismatched object) and cancellation.
#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/errors.hpp"
#include "motion/canopen/sdo_client.hpp"

namespace motion::canopen {
namespace {

using namespace std::chrono_literals;
using test::frame;

const TimePoint t0 = TimePoint{} + 1h;

struct Result {
  std::error_code error;
  std::vector<std::uint8_t> data;
};

class SdoClientTest : public ::testing::Test {
 protected:
  SdoClientTest() : client_([this](const can::Frame& f) { sent_.push_back(f); }, {200ms, 1, 64}) {}

  SdoCallback record(std::optional<Result>& into) {
    return [&into](std::error_code error, std::span<const std::uint8_t> data) {
      into = Result{error, {data.begin(), data.end()}};
    };
  }
  // The frames sent since the last call, as frame text.
  std::vector<std::string> take_sent() {
    auto texts = test::to_texts(sent_);
    sent_.clear();
    return texts;
  }
  void reply(const char* text, TimePoint now = t0) { EXPECT_TRUE(client_.on_frame(frame(text), now)); }

  std::vector<can::Frame> sent_;
  SdoClient client_;
};

using Texts = std::vector<std::string>;

TEST_F(SdoClientTest, ExpeditedDownloadOfTheManualFrame) {
  std::optional<Result> result;
  client_.download(1, {0x6040, 0}, encode_value<std::uint16_t>(0x000F), record(result));
  EXPECT_EQ(client_.next_deadline(), TimePoint::min());  // queued, waits for process()
  EXPECT_EQ(client_.process(t0), t0 + 200ms);
  EXPECT_EQ(take_sent(), Texts{"601: 2B 40 60 00 0F 00 00 00"});  // D-01 / M-05
  EXPECT_TRUE(client_.busy(1));
  reply("581: 60 40 60 00 00 00 00 00");
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
  EXPECT_FALSE(client_.busy(1));
  EXPECT_EQ(client_.next_deadline(), kNever);
}

TEST_F(SdoClientTest, ExpeditedUploadReturnsTheBytes) {
  std::optional<Result> result;
  client_.upload(1, {0x6041, 0}, record(result));
  client_.process(t0);
  EXPECT_EQ(take_sent(), Texts{"601: 40 41 60 00 00 00 00 00"});
  reply("581: 4B 41 60 00 37 02 00 00");  // D-04
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
  EXPECT_EQ(decode_value<std::uint16_t>(result->data), 0x0237);
}

TEST_F(SdoClientTest, SegmentedDownloadD26) {
  std::optional<Result> result;
  client_.download(1, {0x6081, 0}, encode_value<std::uint32_t>(120), record(result), SdoDownloadMode::kSegmented);
  client_.process(t0);
  EXPECT_EQ(take_sent(), Texts{"601: 21 81 60 00 04 00 00 00"});
  reply("581: 60 81 60 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 07 78 00 00 00 00 00 00"});
  reply("581: 20 00 00 00 00 00 00 00");
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
}

TEST_F(SdoClientTest, SegmentedDownloadAlternatesTheToggle) {
  std::optional<Result> result;
  std::vector<std::uint8_t> ten = {'U', 'C', '5', '7', ' ', 'd', 'r', 'i', 'v', 'e'};
  client_.download(1, {0x2000, 0}, ten, record(result));  // > 4 bytes: segmented automatically
  client_.process(t0);
  EXPECT_EQ(take_sent(), Texts{"601: 21 00 20 00 0A 00 00 00"});
  reply("581: 60 00 20 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 00 55 43 35 37 20 64 72"});
  reply("581: 20 00 00 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 19 69 76 65 00 00 00 00"});
  reply("581: 30 00 00 00 00 00 00 00");
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
}

TEST_F(SdoClientTest, SegmentedUploadD28) {
  std::optional<Result> result;
  client_.upload(1, {0x1008, 0}, record(result));
  client_.process(t0);
  take_sent();
  reply("581: 41 08 10 00 0A 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 60 00 00 00 00 00 00 00"});
  reply("581: 00 55 43 35 37 20 64 72");
  EXPECT_EQ(take_sent(), Texts{"601: 70 00 00 00 00 00 00 00"});
  reply("581: 19 69 76 65 00 00 00 00");
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
  EXPECT_EQ(std::string(result->data.begin(), result->data.end()), "UC57 drive");
}

TEST_F(SdoClientTest, SegmentedUploadD27OfTheDeviceType) {
  std::optional<Result> result;
  client_.upload(1, {0x1000, 0}, record(result));
  client_.process(t0);
  take_sent();
  reply("581: 41 00 10 00 04 00 00 00");
  reply("581: 07 92 01 04 00 00 00 00");
  ASSERT_TRUE(result);
  EXPECT_EQ(decode_value<std::uint32_t>(result->data), 0x00040192u);
}

TEST_F(SdoClientTest, ServerAbortCompletesWithItsCodeAndNoRetry) {
  std::optional<Result> result;
  client_.download(1, {0x6041, 0}, encode_value<std::uint16_t>(0), record(result));
  client_.process(t0);
  take_sent();
  reply("581: 80 41 60 00 02 00 01 06");  // D-20
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kWriteOfReadOnly);
  EXPECT_TRUE(take_sent().empty());  // the client does not abort an abort
}

TEST_F(SdoClientTest, TimeoutAbortsRetriesOnceThenFails) {
  std::optional<Result> result;
  client_.upload(1, {0x6064, 0}, record(result));
  client_.process(t0);
  EXPECT_EQ(take_sent(), Texts{"601: 40 64 60 00 00 00 00 00"});
  EXPECT_EQ(client_.process(t0 + 199ms), t0 + 200ms);
  EXPECT_TRUE(take_sent().empty());
  // First timeout: abort 05040000h on the wire, then the initiate again.
  EXPECT_EQ(client_.process(t0 + 200ms), t0 + 400ms);
  EXPECT_EQ(take_sent(), (Texts{"601: 80 64 60 00 00 00 04 05", "601: 40 64 60 00 00 00 00 00"}));
  EXPECT_FALSE(result);
  // Second timeout: no retries left.
  EXPECT_EQ(client_.process(t0 + 400ms), kNever);
  EXPECT_EQ(take_sent(), Texts{"601: 80 64 60 00 00 00 04 05"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kTimeout);
}

TEST_F(SdoClientTest, RetryRestartsASegmentedTransferFromItsInitiate) {
  std::optional<Result> result;
  client_.upload(1, {0x1000, 0}, record(result));
  client_.process(t0);
  take_sent();
  reply("581: 41 00 10 00 04 00 00 00");
  take_sent();
  client_.process(t0 + 200ms);  // the segment reply never comes
  EXPECT_EQ(take_sent(), (Texts{"601: 80 00 10 00 00 00 04 05", "601: 40 00 10 00 00 00 00 00"}));
  reply("581: 43 00 10 00 92 01 04 00", t0 + 210ms);  // now answered expedited
  ASSERT_TRUE(result);
  EXPECT_FALSE(result->error);
  EXPECT_EQ(decode_value<std::uint32_t>(result->data), 0x00040192u);
}

TEST_F(SdoClientTest, WrongToggleAbortsWith05030000) {
  std::optional<Result> result;
  client_.upload(1, {0x1008, 0}, record(result));
  client_.process(t0);
  reply("581: 41 08 10 00 0A 00 00 00");
  take_sent();
  reply("581: 10 55 43 35 37 20 64 72");  // t = 1 where 0 was requested
  EXPECT_EQ(take_sent(), Texts{"601: 80 08 10 00 00 00 03 05"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kToggleBitNotAlternated);
}

TEST_F(SdoClientTest, WrongToggleInADownloadSegmentResponse) {
  std::optional<Result> result;
  client_.download(1, {0x6081, 0}, encode_value<std::uint32_t>(120), record(result), SdoDownloadMode::kSegmented);
  client_.process(t0);
  reply("581: 60 81 60 00 00 00 00 00");
  take_sent();
  reply("581: 30 00 00 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 80 81 60 00 00 00 03 05"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kToggleBitNotAlternated);
}

TEST_F(SdoClientTest, UnexpectedCommandSpecifierAborts) {
  std::optional<Result> result;
  client_.upload(1, {0x6041, 0}, record(result));
  client_.process(t0);
  take_sent();
  reply("581: 60 41 60 00 00 00 00 00");  // a download response to an upload
  EXPECT_EQ(take_sent(), Texts{"601: 80 41 60 00 01 00 04 05"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kInvalidCommandSpecifier);
}

TEST_F(SdoClientTest, MalformedResponseFrameAborts) {
  std::optional<Result> result;
  client_.upload(1, {0x6041, 0}, record(result));
  client_.process(t0);
  take_sent();
  reply("581: 4B 41 60 00 37 02 00");  // 7 bytes
  EXPECT_EQ(take_sent(), Texts{"601: 80 41 60 00 01 00 04 05"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, SdoAbortCode::kInvalidCommandSpecifier);
}

TEST_F(SdoClientTest, ReplyForAnotherObjectIsAMismatch) {
  // Manual V-05: the printed reply to a 60FFh write names 6081h.
  std::optional<Result> result;
  client_.download(1, {0x60FF, 0}, encode_value<std::int32_t>(60), record(result));
  client_.process(t0);
  EXPECT_EQ(take_sent(), Texts{"601: 23 FF 60 00 3C 00 00 00"});
  reply("581: 60 81 60 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 80 FF 60 00 00 00 00 08"});
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, CanopenError::kMismatchedReply);
}

// A busy server answers after the client gave up (its abort crossed the answer on the bus): that
// late answer must not fail the next transfer (the UC57 lab under load: "SDO write 0x6083:00
// failed: SDO reply for another object"), whose own answer still completes it.
TEST_F(SdoClientTest, LateAnswerToAGivenUpRequestIsDropped) {
  std::optional<Result> first;
  std::optional<Result> second;
  client_.download(1, {0x6081, 0}, encode_value<std::uint32_t>(60), record(first));
  client_.download(1, {0x6083, 0}, encode_value<std::uint32_t>(50), record(second));
  client_.process(t0);
  client_.process(t0 + 200ms);  // timeout, retried
  client_.process(t0 + 400ms);  // timeout, given up; 6083h goes out
  ASSERT_TRUE(first);
  EXPECT_EQ(first->error, SdoAbortCode::kTimeout);
  take_sent();
  reply("581: 60 81 60 00 00 00 00 00", t0 + 410ms);  // the late answer to 6081h
  EXPECT_FALSE(second);
  EXPECT_EQ(take_sent(), Texts{});  // nothing aborted
  reply("581: 60 83 60 00 00 00 00 00", t0 + 420ms);
  ASSERT_TRUE(second);
  EXPECT_FALSE(second->error);

  // Idle again: the given-up request is forgotten, another object's reply is a mismatch again.
  std::optional<Result> third;
  client_.download(1, {0x60FF, 0}, encode_value<std::int32_t>(60), record(third));
  client_.process(t0 + 500ms);
  take_sent();
  reply("581: 60 81 60 00 00 00 00 00", t0 + 510ms);
  ASSERT_TRUE(third);
  EXPECT_EQ(third->error, CanopenError::kMismatchedReply);
}

TEST_F(SdoClientTest, SegmentedUploadLengthChecks) {
  std::optional<Result> too_long;
  client_.upload(1, {0x1008, 0}, record(too_long));
  client_.process(t0);
  reply("581: 41 08 10 00 03 00 00 00");
  take_sent();
  reply("581: 07 55 43 35 37 00 00 00");  // 4 bytes where 3 were announced
  EXPECT_EQ(take_sent(), Texts{"601: 80 08 10 00 12 00 07 06"});
  ASSERT_TRUE(too_long);
  EXPECT_EQ(too_long->error, SdoAbortCode::kLengthTooHigh);

  std::optional<Result> too_short;
  client_.upload(1, {0x1008, 0}, record(too_short));
  client_.process(t0);
  reply("581: 41 08 10 00 05 00 00 00");
  take_sent();
  reply("581: 07 55 43 35 37 00 00 00");  // last segment after 4 of 5 bytes
  EXPECT_EQ(take_sent(), Texts{"601: 80 08 10 00 13 00 07 06"});
  ASSERT_TRUE(too_short);
  EXPECT_EQ(too_short->error, SdoAbortCode::kLengthTooLow);

  std::optional<Result> too_big;  // the client was built with max_upload_size 64
  client_.upload(1, {0x1008, 0}, record(too_big));
  client_.process(t0);
  reply("581: 41 08 10 00 00 01 00 00");
  EXPECT_EQ(take_sent().back(), "601: 80 08 10 00 05 00 04 05");
  ASSERT_TRUE(too_big);
  EXPECT_EQ(too_big->error, SdoAbortCode::kOutOfMemory);
}

TEST_F(SdoClientTest, OneTransferPerNodeOthersQueueAndChain) {
  std::optional<Result> first;
  std::optional<Result> second;
  std::optional<Result> other_node;
  client_.download(1, {0x6040, 0}, encode_value<std::uint16_t>(6), record(first));
  client_.download(1, {0x6040, 0}, encode_value<std::uint16_t>(7), record(second));
  client_.upload(2, {0x6041, 0}, record(other_node));
  EXPECT_EQ(client_.pending(1), 2u);
  client_.process(t0);
  // Nodes run in parallel; node 1's second write waits for its first.
  EXPECT_EQ(take_sent(), (Texts{"601: 2B 40 60 00 06 00 00 00", "602: 40 41 60 00 00 00 00 00"}));
  reply("581: 60 40 60 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 2B 40 60 00 07 00 00 00"});  // chained at once
  EXPECT_TRUE(first && !first->error);
  EXPECT_FALSE(second);
  reply("581: 60 40 60 00 00 00 00 00");
  EXPECT_TRUE(second && !second->error);
  EXPECT_FALSE(other_node);
}

TEST_F(SdoClientTest, CallbacksMayChainRequests) {
  std::optional<Result> chained;
  client_.download(1, {0x6060, 0}, encode_value<std::int8_t>(1), [&](std::error_code, std::span<const std::uint8_t>) {
    client_.upload(1, {0x6061, 0}, record(chained));
  });
  client_.process(t0);
  take_sent();
  reply("581: 60 60 60 00 00 00 00 00");
  EXPECT_EQ(take_sent(), Texts{"601: 40 61 60 00 00 00 00 00"});
  reply("581: 4F 61 60 00 01 00 00 00");
  ASSERT_TRUE(chained);
  EXPECT_EQ(decode_value<std::int8_t>(chained->data), 1);
}

TEST_F(SdoClientTest, CancelAbortsTheActiveTransferAndDropsTheQueue) {
  std::vector<std::error_code> errors;
  const auto note = [&](std::error_code e, std::span<const std::uint8_t>) { errors.push_back(e); };
  client_.upload(1, {0x6041, 0}, note);
  client_.upload(1, {0x6064, 0}, note);
  client_.process(t0);
  take_sent();
  client_.cancel(1);
  EXPECT_EQ(take_sent(), Texts{"601: 80 41 60 00 00 00 00 08"});
  EXPECT_EQ(errors, (std::vector<std::error_code>{CanopenError::kCancelled, CanopenError::kCancelled}));
  EXPECT_EQ(client_.pending(1), 0u);
  // A late reply is consumed without effect.
  reply("581: 4B 41 60 00 37 02 00 00");
  EXPECT_EQ(errors.size(), 2u);
}

TEST_F(SdoClientTest, InvalidNodeAndForeignFrames) {
  std::optional<Result> result;
  client_.upload(0, {0x6041, 0}, record(result));
  ASSERT_TRUE(result);
  EXPECT_EQ(result->error, CanopenError::kInvalidArgument);
  client_.upload(128, {0x6041, 0}, record(result));
  EXPECT_EQ(result->error, CanopenError::kInvalidArgument);
  EXPECT_FALSE(client_.on_frame(frame("601: 40 41 60 00 00 00 00 00"), t0));  // a request, not ours
  EXPECT_FALSE(client_.on_frame(frame("181: 37 02 00 00 00 00 01"), t0));
  EXPECT_TRUE(client_.on_frame(frame("585: 60 40 60 00 00 00 00 00"), t0));  // SDO response, no transfer
}

TEST(SdoValues, TypedHelpersAreExactSize) {
  EXPECT_EQ(encode_value<std::int32_t>(-3200), (std::vector<std::uint8_t>{0x80, 0xF3, 0xFF, 0xFF}));
  const std::vector<std::uint8_t> two = {0x37, 0x02};
  EXPECT_EQ(decode_value<std::uint16_t>(two), 0x0237);
  EXPECT_FALSE(decode_value<std::uint32_t>(two));
}

}  // namespace
}  // namespace motion::canopen
