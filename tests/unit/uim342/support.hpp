// Test helpers: the manual writes frames as `ID CW DL d0 d1 ... d7` in hex; these turn such rows
// into messages and CAN frames so that example tables can be transcribed verbatim.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "motion/can_frame/frame.hpp"
#include "motion/uim342/message.hpp"

namespace motion::uim342::test {

inline std::vector<std::uint8_t> hex_bytes(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::string token;
  const auto flush = [&] {
    if (token.empty()) return;
    out.push_back(static_cast<std::uint8_t>(std::stoul(token, nullptr, 16)));
    token.clear();
  };
  for (const char c : text) {
    if (c == ' ') {
      flush();
    } else {
      token.push_back(c);
    }
  }
  flush();
  return out;
}

struct Row {
  std::uint8_t id = 0;
  Message message;
};

// "05 81 01 08 00 00 00 00 00 00 00" -> id 5, CW 0x81, DL 1, d0 = 0x08. Columns after DL beyond
// DL are padding and must be 00 (the normalized rows of the tests guarantee it).
inline Row parse_row(std::string_view text) {
  const auto b = hex_bytes(text);
  Row row;
  if (b.size() < 3) {
    ADD_FAILURE() << "row too short: " << text;
    return row;
  }
  row.id = b[0];
  row.message.control_word = b[1];
  row.message.length = b[2];
  for (std::size_t i = 3; i < b.size(); ++i) {
    const std::size_t d = i - 3;
    if (d < row.message.length) {
      row.message.data.at(d) = b[i];
    } else {
      EXPECT_EQ(b[i], 0) << "non-zero padding in " << text;
    }
  }
  EXPECT_LE(row.message.length, b.size() - 3) << "row shorter than its DL: " << text;
  return row;
}

// The CAN frame that carries `row` with the given identifier (DLC = DL).
inline can::Frame frame_of(std::uint32_t can_id, const Row& row) {
  return *can::Frame::make(can_id, true, row.message.payload());
}

inline can::Frame frame(std::uint32_t can_id, std::string_view data) {
  const auto payload = hex_bytes(data);
  return *can::Frame::make(can_id, true, payload);
}

inline std::string hex(std::span<const std::uint8_t> bytes) {
  std::string out;
  for (const auto b : bytes) {
    static constexpr char kDigits[] = "0123456789ABCDEF";
    if (!out.empty()) out.push_back(' ');
    out.push_back(kDigits[b >> 4]);
    out.push_back(kDigits[b & 0x0F]);
  }
  return out;
}

}  // namespace motion::uim342::test
