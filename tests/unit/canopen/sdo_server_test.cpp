// The passive SDO server (sdo_server.hpp) frame by frame against the manual's and derived vectors,
// and end to end with the SDO client; plus the encoder's handling of an empty expedited value.
#include <gtest/gtest.h>

#include <chrono>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "frame_text.hpp"
#include "motion/canopen/sdo.hpp"
#include "motion/canopen/sdo_client.hpp"
#include "motion/canopen/sdo_server.hpp"

namespace motion::canopen {
namespace {

using namespace std::chrono_literals;
using test::frame;
using Texts = std::vector<std::string>;

const TimePoint t0 = TimePoint{} + 1h;

class SdoServerTest : public ::testing::Test {
 protected:
  SdoServerTest()
      : server_(1, [this](const can::Frame& f) { sent_.push_back(f); },
                {[this](ObjectAddress a) { return read(a); }, [this](const SdoWrite& w) { return write(w); }}) {
    store_[key({0x1000, 0})] = {0x92, 0x01, 0x04, 0x00};
    store_[key({0x6041, 0})] = {0x37, 0x02};
    store_[key({0x1008, 0})] = {'U', 'C', '5', '7', ' ', 'd', 'r', 'i', 'v', 'e'};
    store_[key({0x6081, 0})] = {0x3C, 0, 0, 0};
  }
  static std::uint32_t key(ObjectAddress a) { return (std::uint32_t{a.index} << 8) | a.subindex; }
  SdoReadResult read(ObjectAddress a) {
    const auto it = store_.find(key(a));
    if (it == store_.end()) return {{}, SdoAbortCode::kObjectDoesNotExist};
    return {it->second, std::nullopt};
  }
  std::optional<SdoAbortCode> write(const SdoWrite& w) {
    if (w.object.index == 0x6041) return SdoAbortCode::kWriteOfReadOnly;
    const auto it = store_.find(key(w.object));
    if (it == store_.end()) return SdoAbortCode::kObjectDoesNotExist;
    const auto size = w.size_indicated ? w.data.size() : it->second.size();
    if (size != it->second.size()) return SdoAbortCode::kLengthMismatch;
    it->second.assign(w.data.begin(), w.data.begin() + static_cast<std::ptrdiff_t>(size));
    return std::nullopt;
  }
  Texts exchange(const char* request, TimePoint now = t0) {
    EXPECT_TRUE(server_.on_request(frame(request), now));
    auto texts = test::to_texts(sent_);
    sent_.clear();
    return texts;
  }

  std::vector<can::Frame> sent_;
  std::map<std::uint32_t, std::vector<std::uint8_t>> store_;
  SdoServer server_;
};

TEST_F(SdoServerTest, ExpeditedVectors) {
  EXPECT_EQ(exchange("601: 40 41 60 00 00 00 00 00"), Texts{"581: 4B 41 60 00 37 02 00 00"});  // D-04
  EXPECT_EQ(exchange("601: 40 00 10 00 00 00 00 00"), Texts{"581: 43 00 10 00 92 01 04 00"});  // D-05
  EXPECT_EQ(exchange("601: 23 81 60 00 78 00 00 00"), Texts{"581: 60 81 60 00 00 00 00 00"});  // D-03
  EXPECT_EQ(store_[key({0x6081, 0})], (std::vector<std::uint8_t>{0x78, 0, 0, 0}));
  EXPECT_EQ(exchange("601: 22 81 60 00 3C 00 00 00"), Texts{"581: 60 81 60 00 00 00 00 00"});  // no size
  EXPECT_EQ(exchange("601: 2B 41 60 00 00 00 00 00"), Texts{"581: 80 41 60 00 02 00 01 06"});  // D-20
  EXPECT_EQ(exchange("601: 40 5A 60 00 00 00 00 00"), Texts{"581: 80 5A 60 00 00 00 02 06"});  // D-21
  EXPECT_EQ(exchange("601: 2B 81 60 00 3C 00 00 00"), Texts{"581: 80 81 60 00 10 00 07 06"});  // D-25 style
}

TEST_F(SdoServerTest, SegmentedDownloadD26) {
  EXPECT_EQ(exchange("601: 21 81 60 00 04 00 00 00"), Texts{"581: 60 81 60 00 00 00 00 00"});
  EXPECT_TRUE(server_.in_transfer());
  EXPECT_EQ(exchange("601: 07 78 00 00 00 00 00 00"), Texts{"581: 20 00 00 00 00 00 00 00"});
  EXPECT_FALSE(server_.in_transfer());
  EXPECT_EQ(store_[key({0x6081, 0})], (std::vector<std::uint8_t>{0x78, 0, 0, 0}));
}

TEST_F(SdoServerTest, SegmentedUploadD28AndToggleError) {
  EXPECT_EQ(exchange("601: 40 08 10 00 00 00 00 00"), Texts{"581: 41 08 10 00 0A 00 00 00"});
  EXPECT_EQ(exchange("601: 60 00 00 00 00 00 00 00"), Texts{"581: 00 55 43 35 37 20 64 72"});
  EXPECT_EQ(exchange("601: 70 00 00 00 00 00 00 00"), Texts{"581: 19 69 76 65 00 00 00 00"});
  EXPECT_FALSE(server_.in_transfer());
  exchange("601: 40 08 10 00 00 00 00 00");
  EXPECT_EQ(exchange("601: 70 00 00 00 00 00 00 00"), Texts{"581: 80 08 10 00 00 00 03 05"});
}

TEST_F(SdoServerTest, ProtocolErrorsAndStallTimeout) {
  EXPECT_EQ(exchange("601: 60 00 00 00 00 00 00 00"), Texts{"581: 80 00 00 00 01 00 04 05"});  // no transfer
  EXPECT_EQ(exchange("601: C6 00 10 00 00 00 00 00"), Texts{"581: 80 00 10 00 01 00 04 05"});  // block
  EXPECT_EQ(exchange("601: 40 41 60 00"), Texts{"581: 80 41 60 00 01 00 04 05"});              // short
  EXPECT_FALSE(server_.on_request(frame("602: 40 41 60 00 00 00 00 00"), t0));                 // other node
  exchange("601: 21 81 60 00 04 00 00 00");
  EXPECT_EQ(server_.next_deadline(), t0 + 1s);
  EXPECT_EQ(server_.process(t0 + 1s), kNever);
  EXPECT_EQ(test::to_texts(sent_), Texts{"581: 80 81 60 00 00 00 04 05"});
  sent_.clear();
  // A client abort ends a transfer silently.
  exchange("601: 21 81 60 00 04 00 00 00");
  EXPECT_TRUE(exchange("601: 80 81 60 00 00 00 04 05").empty());
  EXPECT_FALSE(server_.in_transfer());
  // Announced 4, sent 5.
  exchange("601: 21 81 60 00 04 00 00 00");
  EXPECT_EQ(exchange("601: 05 01 02 03 04 05 00 00"), Texts{"581: 80 81 60 00 10 00 07 06"});
}

TEST_F(SdoServerTest, ClientAndServerEndToEnd) {
  std::vector<can::Frame> to_server;
  SdoClient client([&](const can::Frame& f) { to_server.push_back(f); });
  std::vector<std::uint8_t> name;
  std::error_code write_error;
  client.upload(1, {0x1008, 0},
                [&](std::error_code, std::span<const std::uint8_t> d) { name.assign(d.begin(), d.end()); });
  client.download(1, {0x1008, 0}, {'a', 'b', 'c', 'd', 'e', 'f', 'g', 'h', 'i', 'j'},
                  [&](std::error_code e, std::span<const std::uint8_t>) { write_error = e; });
  client.process(t0);
  for (int guard = 0; guard < 20 && !to_server.empty(); ++guard) {
    const can::Frame request = to_server.front();
    to_server.erase(to_server.begin());
    server_.on_request(request, t0);
    for (const auto& reply : sent_) client.on_frame(reply, t0);
    sent_.clear();
  }
  EXPECT_EQ(std::string(name.begin(), name.end()), "UC57 drive");
  EXPECT_FALSE(write_error);
  EXPECT_EQ(std::string(store_[key({0x1008, 0})].begin(), store_[key({0x1008, 0})].end()), "abcdefghij");
}

TEST(SdoCodecEdge, EmptyExpeditedValueGoesOutAsASegmentedInitiate) {
  // Regression: n = 4 overflowed into the reserved bit 4 (0x33 instead of a valid command byte).
  const SdoInitiateData empty = SdoInitiateData::expedited_data({0x2000, 0}, {});
  EXPECT_EQ(sdo_request_frame(1, SdoInitiateDownloadRequest{empty}), frame("601: 21 00 20 00 00 00 00 00"));
}

}  // namespace
}  // namespace motion::canopen
