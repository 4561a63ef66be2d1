#include "motion/can_frame/frame.hpp"

#include <charconv>
#include <cstdio>

namespace motion::can {
namespace {

std::optional<std::uint32_t> parse_hex(std::string_view s) {
  if (s.empty()) return std::nullopt;
  std::uint32_t v = 0;
  auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v, 16);
  if (ec != std::errc{} || end != s.data() + s.size()) return std::nullopt;
  return v;
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

std::optional<Frame> Frame::make(std::uint32_t id, bool extended, std::span<const std::uint8_t> payload) {
  if (payload.size() > 8) return std::nullopt;
  if (id > (extended ? kMaxExtendedId : kMaxStandardId)) return std::nullopt;
  Frame f;
  f.id = id;
  f.extended = extended;
  f.dlc = static_cast<std::uint8_t>(payload.size());
  std::copy(payload.begin(), payload.end(), f.data.begin());
  return f;
}

std::optional<Frame> parse_cansend(std::string_view text) {
  const auto hash = text.find('#');
  if (hash == std::string_view::npos) return std::nullopt;
  const std::string_view id_text = text.substr(0, hash);
  std::string_view data_text = text.substr(hash + 1);
  // cansend: 3 hex digits = standard id, 8 hex digits = extended id.
  if (id_text.size() != 3 && id_text.size() != 8) return std::nullopt;
  const auto id = parse_hex(id_text);
  if (!id) return std::nullopt;
  Frame f;
  f.extended = id_text.size() == 8;
  f.id = *id;
  if (f.id > (f.extended ? kMaxExtendedId : kMaxStandardId)) return std::nullopt;
  if (!data_text.empty() && (data_text[0] == 'R' || data_text[0] == 'r')) {
    f.rtr = true;
    if (data_text.size() == 2 && data_text[1] >= '0' && data_text[1] <= '8') {
      f.dlc = static_cast<std::uint8_t>(data_text[1] - '0');
    } else if (data_text.size() != 1) {
      return std::nullopt;
    }
    return f;
  }
  std::size_t n = 0;
  for (std::size_t i = 0; i < data_text.size();) {
    if (data_text[i] == '.') {  // cansend allows '.' separators between bytes
      ++i;
      continue;
    }
    if (i + 1 >= data_text.size() || n == 8) return std::nullopt;
    const int hi = hex_digit(data_text[i]);
    const int lo = hex_digit(data_text[i + 1]);
    if (hi < 0 || lo < 0) return std::nullopt;
    f.data[n++] = static_cast<std::uint8_t>(hi * 16 + lo);
    i += 2;
  }
  f.dlc = static_cast<std::uint8_t>(n);
  return f;
}

std::string to_cansend(const Frame& frame) {
  char buf[48];
  int len = std::snprintf(buf, sizeof buf, frame.extended ? "%08X#" : "%03X#", frame.id);
  std::string out(buf, static_cast<std::size_t>(len));
  if (frame.rtr) {
    out += 'R';
    if (frame.dlc != 0) out += static_cast<char>('0' + frame.dlc);
    return out;
  }
  for (std::size_t i = 0; i < frame.dlc; ++i) {
    std::snprintf(buf, sizeof buf, "%02X", frame.data[i]);
    out += buf;
  }
  return out;
}

std::string to_candump_line(const Frame& frame, std::string_view interface) {
  char ts[40];
  const auto us = frame.timestamp_us;
  std::snprintf(ts, sizeof ts, "(%lld.%06lld) ", static_cast<long long>(us / 1000000),
                static_cast<long long>(us % 1000000));
  std::string out = ts;
  out.append(interface);
  out += ' ';
  out += to_cansend(frame);
  return out;
}

std::optional<LogLine> parse_candump_line(std::string_view line) {
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
  if (line.size() < 4 || line.front() != '(') return std::nullopt;
  const auto close = line.find(')');
  if (close == std::string_view::npos) return std::nullopt;
  const std::string_view ts = line.substr(1, close - 1);
  const auto dot = ts.find('.');
  if (dot == std::string_view::npos || ts.size() - dot - 1 != 6) return std::nullopt;
  long long sec = 0;
  long long usec = 0;
  if (std::from_chars(ts.data(), ts.data() + dot, sec).ec != std::errc{}) return std::nullopt;
  if (std::from_chars(ts.data() + dot + 1, ts.data() + ts.size(), usec).ec != std::errc{}) return std::nullopt;
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ') return std::nullopt;
  rest.remove_prefix(1);
  const auto space = rest.find(' ');
  if (space == std::string_view::npos || space == 0) return std::nullopt;
  auto frame = parse_cansend(rest.substr(space + 1));
  if (!frame) return std::nullopt;
  frame->timestamp_us = sec * 1000000 + usec;
  return LogLine{frame->timestamp_us, std::string(rest.substr(0, space)), *frame};
}

}  // namespace motion::can
