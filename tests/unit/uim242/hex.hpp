// Test helper: the manuals write feedback frames as hex byte rows ("AA 05 B0 02 0E 33 FF").
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace motion::uim242::test {

inline std::vector<std::uint8_t> hex(std::string_view text) {
  std::vector<std::uint8_t> out;
  std::string token;
  const auto flush = [&] {
    if (!token.empty()) out.push_back(static_cast<std::uint8_t>(std::stoul(token, nullptr, 16)));
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

}  // namespace motion::uim242::test
