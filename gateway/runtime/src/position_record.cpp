#include "motion/gateway/position_record.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cstring>
#include <fstream>
#include <sstream>
#include <vector>

#include "motion/core/durable_file.hpp"

namespace motion::gateway {

namespace {

constexpr const char* kHeader = "# motionbus gateway position record v1";

std::vector<std::string> split_tabs(const std::string& line) {
  std::vector<std::string> fields;
  std::size_t start = 0;
  while (true) {
    const std::size_t tab = line.find('\t', start);
    fields.push_back(line.substr(start, tab == std::string::npos ? std::string::npos : tab - start));
    if (tab == std::string::npos) return fields;
    start = tab + 1;
  }
}

std::optional<std::int64_t> to_int(const std::string& text) {
  std::int64_t value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc{} || end != text.data() + text.size()) return std::nullopt;
  return value;
}

// Tabs and line ends would break the line apart: a reason is one line of text.
std::string one_line(std::string text) {
  std::replace_if(
      text.begin(), text.end(), [](char c) { return c == '\t' || c == '\n' || c == '\r'; }, ' ');
  return text;
}

}  // namespace

std::string PositionRecords::format(const std::map<std::string, AxisRecord>& records) {
  std::string out = std::string(kHeader) +
                    "\n# axis, position (counts), target (counts), rest|moving, homed|not-homed, "
                    "why the position is lost (empty: valid)\n";
  for (const auto& [axis, r] : records) {
    out += fmt::format("{}\t{}\t{}\t{}\t{}\t{}\n", one_line(axis), r.position_counts, r.target_counts,
                       r.moving ? "moving" : "rest", r.homed ? "homed" : "not-homed", one_line(r.lost));
  }
  return out;
}

std::string PositionRecords::parse(const std::string& text, std::map<std::string, AxisRecord>& records) {
  records.clear();
  std::istringstream in(text);
  std::string line;
  int number = 0;
  bool header = false;
  while (std::getline(in, line)) {
    ++number;
    if (number == 1) {
      if (line != kHeader) return fmt::format("line 1 is not \"{}\"", kHeader);
      header = true;
      continue;
    }
    if (line.empty() || line[0] == '#') continue;
    const auto f = split_tabs(line);
    const auto position = f.size() == 6 ? to_int(f[1]) : std::nullopt;
    const auto target = f.size() == 6 ? to_int(f[2]) : std::nullopt;
    if (!position || !target || f[0].empty() || (f[3] != "rest" && f[3] != "moving") ||
        (f[4] != "homed" && f[4] != "not-homed")) {
      records.clear();
      return fmt::format("line {} is not <axis> <counts> <counts> rest|moving homed|not-homed <why lost> (tabs)",
                         number);
    }
    records[f[0]] = AxisRecord{*position, *target, f[3] == "moving", f[4] == "homed", f[5]};
  }
  if (!header) return "the file is empty";
  return {};
}

std::string PositionRecords::load() {
  records_.clear();
  if (::access(path_.c_str(), F_OK) != 0 && errno == ENOENT) return {};  // first start: nothing known
  std::ifstream in(path_);
  if (!in) return fmt::format("cannot read {}: {}", path_, std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (std::string why = parse(text.str(), records_); !why.empty()) return path_ + ": " + why;
  return {};
}

const AxisRecord* PositionRecords::find(const std::string& axis) const {
  const auto it = records_.find(axis);
  return it == records_.end() ? nullptr : &it->second;
}

bool PositionRecords::update(const std::string& axis, const AxisRecord& record) {
  auto [it, added] = records_.try_emplace(axis, record);
  if (added) return true;
  if (it->second == record) return false;
  it->second = record;
  return true;
}

std::string PositionRecords::text() const { return format(records_); }

std::string PositionRecords::save() const { return write_file_durably(path_, text()); }

std::optional<std::string> power_cycle_evidence(const AxisRecord& record, const DriveStatus& status,
                                                bool drive_keeps_homed, std::int64_t tolerance,
                                                const std::string& drive) {
  if (drive_keeps_homed && record.homed && !record.moving && !status.homed) {
    return fmt::format(
        "{} powered up or was reset while no gateway ran, detected by the position record: it no longer reports "
        "homed, which it was when the previous gateway process stopped",
        drive);
  }
  const std::int64_t low =
      (record.moving ? std::min(record.position_counts, record.target_counts) : record.position_counts) - tolerance;
  const std::int64_t high =
      (record.moving ? std::max(record.position_counts, record.target_counts) : record.position_counts) + tolerance;
  if (status.position_counts >= low && status.position_counts <= high) return std::nullopt;
  if (record.moving) {
    return fmt::format(
        "{} powered up or was reset while no gateway ran, detected by the position record: it answers at {} counts, "
        "outside the move from {} to {} counts it was making when the previous gateway process stopped",
        drive, status.position_counts, record.position_counts, record.target_counts);
  }
  return fmt::format(
      "{} powered up or was reset while no gateway ran, detected by the position record: it answers at {} counts, {} "
      "counts were recorded at rest when the previous gateway process stopped",
      drive, status.position_counts, record.position_counts);
}

}  // namespace motion::gateway
