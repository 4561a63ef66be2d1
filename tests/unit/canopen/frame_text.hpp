// Test helper shared by the CANopen and UC57 simulator tests: the tests and the manual write CAN
// frames as `601: 2B 40 60 00 0F 00 00 00` (COB-ID, colon, data bytes in hex; `080:` has none;
// the manual's `00:` and `581:60 ...` spellings are accepted as printed). These helpers turn such
// text into frames and payloads so the example tables are transcribed verbatim.
#pragma once

#include <gtest/gtest.h>

#include <cctype>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "motion/can_frame/frame.hpp"

namespace motion::canopen::test {

// "2B 40 60 00" -> {0x2B, 0x40, 0x60, 0x00}; whitespace separates bytes.
inline std::vector<std::uint8_t> hex_bytes(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::string token;
  const auto flush = [&] {
    if (token.empty()) return;
    out.push_back(static_cast<std::uint8_t>(std::stoul(token, nullptr, 16)));
    token.clear();
  };
  for (const char c : text) {
    if (std::isspace(static_cast<unsigned char>(c)) != 0) {
      flush();
    } else {
      token.push_back(c);
    }
  }
  flush();
  return out;
}

// "601: 2B 40 60 00 0F 00 00 00" -> standard data frame 601h, DLC 8.
inline can::Frame frame(std::string_view text) {
  const auto colon = text.find(':');
  if (colon == std::string_view::npos) {
    ADD_FAILURE() << "frame text without ':' " << text;
    return {};
  }
  const auto id = static_cast<std::uint32_t>(std::stoul(std::string(text.substr(0, colon)), nullptr, 16));
  const auto data = hex_bytes(text.substr(colon + 1));
  const auto made = can::Frame::make(id, false, data);
  if (!made) {
    ADD_FAILURE() << "not a valid standard frame: " << text;
    return {};
  }
  return *made;
}

// The payload of a frame text (what the codecs take).
inline std::vector<std::uint8_t> payload(std::string_view text) {
  const can::Frame f = frame(text);
  return {f.payload().begin(), f.payload().end()};
}

// "601: 2B ..." for failure messages.
inline std::string to_text(const can::Frame& f) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string out;
  out += kHex[(f.id >> 8) & 0xF];
  out += kHex[(f.id >> 4) & 0xF];
  out += kHex[f.id & 0xF];
  out += ':';
  for (const std::uint8_t b : f.payload()) {
    out += ' ';
    out += kHex[b >> 4];
    out += kHex[b & 0xF];
  }
  return out;
}

inline std::vector<std::string> to_texts(std::span<const can::Frame> frames) {
  std::vector<std::string> out;
  for (const auto& f : frames) out.push_back(to_text(f));
  return out;
}

}  // namespace motion::canopen::test
