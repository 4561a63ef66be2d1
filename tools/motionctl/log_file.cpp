// motionctl log's reader of LCM event logs (log_file.hpp).
#include <lcm/eventlog.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include <motionlcm/axis_state_t.hpp>
#include <motionlcm/reply_t.hpp>
#include <motionlcm/request_t.hpp>

#include "motion/client/client.hpp"
#include "motion/core/log.hpp"
#include "motion/lcm/channels.hpp"
#include "motion/lcm/request_kinds.hpp"
#include "motion/web/svg_plot.hpp"

#include "log_file.hpp"
#include "motionctl.hpp"

namespace motion::ctl {
namespace {

using motionlcm::axis_state_t;
using motionlcm::reply_t;
using motionlcm::request_t;

constexpr std::uint32_t kMagic = 0xEDA1DA01U;            // LCM event log record marker (big endian)
constexpr std::int64_t kHeaderSize = 4 + 8 + 8 + 4 + 4;  // magic, eventnum, timestamp, channel length, data length

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
struct EventlogCloser {
  void operator()(lcm_eventlog_t* l) const { lcm_eventlog_destroy(l); }
};
struct EventFree {
  void operator()(lcm_eventlog_event_t* e) const { lcm_eventlog_free_event(e); }
};

std::uint64_t big_endian(const unsigned char* p, int bytes) {
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

// Checks the record header at `offset` through a second handle, so LCM's reader is only called on a
// record that is whole. Returns nullopt when the record is sound; else what is wrong with it, and
// sets `truncated` when the file merely ends inside the record.
std::optional<std::string> check_record(std::FILE* peek, std::int64_t offset, std::int64_t file_size, bool& truncated) {
  truncated = false;
  std::array<unsigned char, kHeaderSize> header{};
  if (::fseeko(peek, offset, SEEK_SET) != 0) return "cannot seek: " + std::string(std::strerror(errno));
  const std::size_t got = std::fread(header.data(), 1, header.size(), peek);
  const auto magic = static_cast<std::uint32_t>(big_endian(header.data(), 4));
  if (got < 4 || magic != kMagic) {
    if (got < 4 && offset + static_cast<std::int64_t>(got) == file_size) {
      // A few bytes that may be the start of a magic word.
      truncated = std::memcmp(header.data(), "\xED\xA1\xDA\x01", got) == 0;
      if (truncated) return "the file ends inside a record header";
    }
    return "no record marker (0xEDA1DA01) at byte offset " + std::to_string(offset) +
           ": not an LCM event log, or damaged";
  }
  if (got < header.size()) {
    truncated = true;
    return "the file ends inside a record header";
  }
  const auto channel_len = static_cast<std::int32_t>(big_endian(header.data() + 20, 4));
  const auto data_len = static_cast<std::int32_t>(big_endian(header.data() + 24, 4));
  if (channel_len <= 0 || channel_len >= 1000) {
    return "record at byte offset " + std::to_string(offset) + " has an invalid channel length " +
           std::to_string(channel_len);
  }
  if (data_len < 0)
    return "record at byte offset " + std::to_string(offset) + " has an invalid data length " +
           std::to_string(data_len);
  const std::int64_t end = offset + kHeaderSize + channel_len + data_len;
  if (end > file_size) {
    truncated = true;
    return "the file ends inside the record at byte offset " + std::to_string(offset) + " (" +
           std::to_string(end - file_size) + " bytes missing)";
  }
  return std::nullopt;
}

struct RawRecord {
  std::int64_t timestamp = 0;
  std::string channel;
  std::vector<std::uint8_t> data;
};

// Header fields of the (checked) record at `offset`.
bool read_header(std::FILE* peek, std::int64_t offset, std::int64_t& timestamp, std::int32_t& channel_len,
                 std::int32_t& data_len) {
  std::array<unsigned char, kHeaderSize> header{};
  if (::fseeko(peek, offset, SEEK_SET) != 0 || std::fread(header.data(), 1, header.size(), peek) != header.size())
    return false;
  timestamp = static_cast<std::int64_t>(big_endian(header.data() + 12, 8));
  channel_len = static_cast<std::int32_t>(big_endian(header.data() + 20, 4));
  data_len = static_cast<std::int32_t>(big_endian(header.data() + 24, 4));
  return true;
}

std::int64_t record_end(std::FILE* peek, std::int64_t offset) {
  std::int64_t timestamp = 0;
  std::int32_t channel_len = 0;
  std::int32_t data_len = 0;
  if (!read_header(peek, offset, timestamp, channel_len, data_len)) return offset;
  return offset + kHeaderSize + channel_len + data_len;
}

bool marker_at(std::FILE* peek, std::int64_t offset) {
  std::array<unsigned char, 4> m{};
  if (::fseeko(peek, offset, SEEK_SET) != 0 || std::fread(m.data(), 1, m.size(), peek) != m.size()) return false;
  return static_cast<std::uint32_t>(big_endian(m.data(), 4)) == kMagic;
}

std::optional<RawRecord> read_record(std::FILE* peek, std::int64_t offset) {
  RawRecord r;
  std::int32_t channel_len = 0;
  std::int32_t data_len = 0;
  if (!read_header(peek, offset, r.timestamp, channel_len, data_len)) return std::nullopt;
  r.channel.resize(static_cast<std::size_t>(channel_len));
  r.data.resize(static_cast<std::size_t>(data_len));
  if (std::fread(r.channel.data(), 1, r.channel.size(), peek) != r.channel.size()) return std::nullopt;
  if (std::fread(r.data.data(), 1, r.data.size(), peek) != r.data.size()) return std::nullopt;
  return r;
}

// Reads the whole log. nullopt (with a message on stderr) when it cannot be opened at all.
}  // namespace

std::optional<LogContents> read_log(const std::string& path, const std::string& prefix) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    std::cerr << "motionctl: cannot open log '" << path << "': " << (ec ? ec.message() : std::strerror(ENOENT)) << "\n";
    return std::nullopt;
  }
  if (!std::filesystem::is_regular_file(status)) {
    std::cerr << "motionctl: cannot read log '" << path << "': not a regular file\n";
    return std::nullopt;
  }
  std::unique_ptr<std::FILE, FileCloser> peek(std::fopen(path.c_str(), "rb"));
  if (!peek) {
    std::cerr << "motionctl: cannot open log '" << path << "': " << std::strerror(errno) << "\n";
    return std::nullopt;
  }
  std::unique_ptr<lcm_eventlog_t, EventlogCloser> log(lcm_eventlog_create(path.c_str(), "r"));
  if (!log) {
    std::cerr << "motionctl: cannot open log '" << path << "': " << std::strerror(errno) << "\n";
    return std::nullopt;
  }
  const auto file_size = static_cast<std::int64_t>(std::filesystem::file_size(path, ec));

  const std::string request_ch = prefix + std::string(lcm::channels::kRequest);
  const std::string reply_ch = prefix + std::string(lcm::channels::kReply);
  const std::string state_ch = prefix + std::string(lcm::channels::kAxisState);
  std::set<std::string> undecodable_channels;

  LogContents out;
  auto add = [&](std::int64_t timestamp, const std::string& channel, const void* data, int size) {
    if (out.events == 0) out.first_utime = timestamp;
    out.last_utime = std::max(out.last_utime, timestamp);
    ++out.events;
    ++out.channel_counts[channel];
    bool ok = true;
    if (channel == request_ch) {
      Logged<request_t> r{timestamp, request_t{}};
      ok = r.msg.decode(data, 0, size) == size;
      if (ok) out.requests.push_back(std::move(r));
    } else if (channel == reply_ch) {
      Logged<reply_t> r{timestamp, reply_t{}};
      ok = r.msg.decode(data, 0, size) == size;
      if (ok) out.replies.push_back(std::move(r));
    } else if (channel == state_ch) {
      Logged<axis_state_t> st{timestamp, axis_state_t{}};
      ok = st.msg.decode(data, 0, size) == size;
      if (ok) out.states.push_back(std::move(st));
    }
    if (!ok) {
      ++out.undecodable;
      undecodable_channels.insert(channel);
    }
  };
  std::int64_t offset = 0;
  while (offset < file_size) {
    bool truncated = false;
    if (auto problem = check_record(peek.get(), offset, file_size, truncated)) {
      if (truncated) {
        out.truncated = *problem;
      } else {
        out.corruption = *problem;
      }
      break;
    }
    // LCM 1.3.1 also refuses a sound record when the bytes after it are not a record marker; such
    // a last good record is read here from the checked header instead, then the damage reported.
    const std::int64_t end = record_end(peek.get(), offset);
    if (end + 4 <= file_size && !marker_at(peek.get(), end)) {
      if (auto last = read_record(peek.get(), offset))
        add(last->timestamp, last->channel, last->data.data(), static_cast<int>(last->data.size()));
      out.corruption = "no record marker (0xEDA1DA01) at byte offset " + std::to_string(end) + " after a record";
      break;
    }
    std::unique_ptr<lcm_eventlog_event_t, EventFree> e(lcm_eventlog_read_next_event(log.get()));
    if (!e) {
      out.corruption = "LCM could not read the record at byte offset " + std::to_string(offset);
      break;
    }
    offset = static_cast<std::int64_t>(::ftello(log->f));
    add(e->timestamp, std::string(e->channel, static_cast<std::size_t>(e->channellen)), e->data, e->datalen);
  }
  out.undecodable_channels.assign(undecodable_channels.begin(), undecodable_channels.end());
  return out;
}

}  // namespace motion::ctl
