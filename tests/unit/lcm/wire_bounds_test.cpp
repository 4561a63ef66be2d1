// Bounded checking of LCM messages (motion/lcm/wire_reader.hpp and the checkers generated from
// lcmtypes/*.lcm). Table-driven over wire::all_types(): a type added to lcmtypes/ is covered by
// these tests without being named here.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <vector>

#include "motion/lcm/wire_bounds.hpp"

namespace motion::lcm::wire {
namespace {

std::vector<std::uint8_t> encode(const auto& msg) {
  const int size = msg.getEncodedSize();
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(size));
  EXPECT_EQ(msg.encode(bytes.data(), 0, size), size);
  return bytes;
}

void put_be(std::vector<std::uint8_t>& bytes, std::size_t offset, int width, std::int64_t value) {
  auto v = static_cast<std::uint64_t>(value);
  for (int i = width - 1; i >= 0; --i) {
    bytes[offset + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v & 0xff);
    v >>= 8;
  }
}

motionlcm::gateway_command_t sample_command() {
  motionlcm::gateway_command_t c{};
  c.bus = "can0";
  c.command_id = 7;
  c.kind = motionlcm::gateway_command_t::ARM_MOVE;
  c.num_axes = 2;
  c.axes.resize(2);
  c.axes[0].axis = "x";
  c.axes[0].target_counts = 1000;
  c.axes[1].axis = "y";
  c.param.mnemonic = "MCFG";
  return c;
}

TEST(WireBounds, EveryLcmFileHasAChecker) {
  const char* source = std::getenv("MOTION_SOURCE_DIR");
  ASSERT_NE(source, nullptr) << "ctest sets MOTION_SOURCE_DIR";
  std::set<std::string> files;
  for (const auto& entry : std::filesystem::directory_iterator(std::filesystem::path(source) / "lcmtypes")) {
    if (entry.path().extension() == ".lcm") files.insert(entry.path().filename().string());
  }
  ASSERT_FALSE(files.empty());
  std::set<std::string> covered;
  for (const auto& t : all_types()) covered.insert(t.lcm_file);
  EXPECT_EQ(files, covered) << "every lcmtypes/*.lcm must be in the generated table (re-run cmake)";
}

TEST(WireBounds, DefaultEncodingOfEveryTypeIsAccepted) {
  for (const auto& t : all_types()) {
    const auto bytes = t.encode_default();
    EXPECT_EQ(t.check(bytes.data(), bytes.size()), "") << t.name;
  }
}

TEST(WireBounds, FilledMessagesAreAcceptedAndDecodeEqual) {
  const auto cmd = sample_command();
  auto bytes = encode(cmd);
  motionlcm::gateway_command_t out;
  ASSERT_EQ(decode_bounded(bytes.data(), bytes.size(), out), "");
  EXPECT_EQ(out.axes.at(1).axis, "y");
  EXPECT_EQ(out.param.mnemonic, "MCFG");

  motionlcm::health_t h{};
  h.process = "gateway:can0";
  h.num_buses = 1;
  h.buses.resize(1);
  h.buses[0].name = "can0";
  bytes = encode(h);
  EXPECT_EQ(check_message<motionlcm::health_t>(bytes.data(), bytes.size()), "");

  motionlcm::can_frame_t f{};
  f.dlc = 3;
  f.data = {1, 2, 3};
  bytes = encode(f);
  EXPECT_EQ(check_message<motionlcm::can_frame_t>(bytes.data(), bytes.size()), "");
}

// Every array count and every string length of every type, set to what a hostile sender would
// claim, is refused, and the reason names the field.
TEST(WireBounds, EveryCountAndStringLengthOfEveryTypeIsBounded) {
  std::size_t checked = 0;
  for (const auto& t : all_types()) {
    const auto base = t.encode_default();
    for (const auto& field : t.count_fields) {
      std::vector<std::int64_t> hostile = {-1};
      if (field.width == 1) {
        hostile.push_back(127);
      } else {
        hostile.insert(hostile.end(), {20'000'000, 0x7fffffff, static_cast<std::int64_t>(base.size())});
      }
      if (field.string_length) hostile.push_back(0);  // a string's length includes its NUL
      for (const std::int64_t value : hostile) {
        auto bytes = base;
        put_be(bytes, field.offset, field.width, value);
        const std::string why = t.check(bytes.data(), bytes.size());
        EXPECT_NE(why, "") << t.name << "." << field.path << " = " << value << " accepted";
        const std::string leaf = std::string(field.path).substr(std::string(field.path).rfind('.') + 1);
        EXPECT_NE(why.find(leaf), std::string::npos) << why;
        ++checked;
      }
    }
  }
  EXPECT_GT(checked, 40u);
}

TEST(WireBounds, HostileGatewayCommandIsRefusedWithCountAndBytes) {
  // 74 bytes claiming 20 million axis commands: lcm-gen's decode would resize to that first.
  auto bytes = encode(sample_command());
  bytes.resize(74, 0);
  put_be(bytes, 46 + 4, 4, 20'000'000);  // num_axes follows "can0": 8+8+9+8+8+1+8
  const std::string why = check_message<motionlcm::gateway_command_t>(bytes.data(), bytes.size());
  EXPECT_NE(why.find("gateway_command_t.axes[num_axes]: count 20000000 needs at least"), std::string::npos) << why;
  EXPECT_NE(why.find("remain"), std::string::npos) << why;
}

TEST(WireBounds, EveryTruncationAndTrailingByteIsRefused) {
  const auto bytes = encode(sample_command());
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    EXPECT_NE(check_message<motionlcm::gateway_command_t>(bytes.data(), n), "") << "prefix of " << n << " bytes";
  }
  auto longer = bytes;
  longer.push_back(0);
  EXPECT_NE(check_message<motionlcm::gateway_command_t>(longer.data(), longer.size()).find("trailing"),
            std::string::npos);
}

TEST(WireBounds, WrongTypeAndMissingNulAreRefused) {
  const auto bytes = encode(sample_command());
  const std::string why = check_message<motionlcm::request_t>(bytes.data(), bytes.size());
  EXPECT_NE(why.find("not a motionlcm.request_t"), std::string::npos) << why;

  auto no_nul = bytes;
  no_nul[16 + 4 + 4] = 'x';  // "can0\0" -> "can0x"
  EXPECT_NE(check_message<motionlcm::gateway_command_t>(no_nul.data(), no_nul.size()).find("NUL"), std::string::npos);
}

// Any single int32 written anywhere in any type's default encoding either is refused or leaves
// a message that lcm-gen decodes to exactly its size (the checker never lets a bad one through).
TEST(WireBounds, CheckerAgreesWithDecodeOnEveryOverwrittenWord) {
  for (const auto& t : all_types()) {
    const auto base = t.encode_default();
    for (std::size_t off = 8; off + 4 <= base.size(); ++off) {
      for (const std::int64_t value : {std::int64_t{-1}, std::int64_t{2}, std::int64_t{1'000'000}}) {
        auto bytes = base;
        put_be(bytes, off, 4, value);
        (void)t.check(bytes.data(), bytes.size());  // must not crash or read out of bounds (ASan build)
      }
    }
  }
  // For the decodable ones, the typed path: checked => lcm decode succeeds.
  auto bytes = encode(sample_command());
  for (std::size_t off = 8; off + 4 <= bytes.size(); ++off) {
    auto b = bytes;
    put_be(b, off, 4, 3);
    motionlcm::gateway_command_t out;
    const std::string why = decode_bounded(b.data(), b.size(), out);
    EXPECT_EQ(why.find("lcm decode refused"), std::string::npos) << "offset " << off << ": " << why;
  }
}

}  // namespace
}  // namespace motion::lcm::wire
