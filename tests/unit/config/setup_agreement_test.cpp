// A file that loads is a file that runs: every set-up value the configuration schema accepts
// (setup_schema.cpp: range ends and every listed value) is accepted by the family's stack when it
// turns the set-up into what it writes to the drive, within the manual's register ranges; and a
// value just beyond the schema is refused at load time, naming the key.
#include <gtest/gtest.h>

#include <cmath>
#include <sstream>

#include "motion/adam/registers.hpp"
#include "motion/adam_driver/adam_stack.hpp"
#include "motion/config/config.hpp"
#include "motion/config/setup_schema.hpp"
#include "motion/uc57_driver/node_settings.hpp"

namespace motion::config {
namespace {

std::string with_setup(Family family, const std::string& key, const std::string& value) {
  const bool can = family == Family::kUc57 || family == Family::kUim342;
  std::ostringstream y;
  y << "buses:\n  - {name: b, transport: " << (can ? "simcan:b" : "simserial:b") << "}\n"
    << "drives:\n  - {name: d, family: " << to_string(family)
    << ", bus: b, node_id: " << (family == Family::kUim342 || family == Family::kUim242 ? 5 : 1) << ", setup: {" << key
    << ": " << value << "}}\n"
    << "axes:\n  - {name: a, drive: d, steps_per_unit: 100, limits: {min: -10, max: 10, velocity: 5, acceleration: "
       "50}}\n";
  return y.str();
}

std::string text(double v) {
  if (v == std::floor(v) && std::abs(v) < 1e15) return std::to_string(static_cast<long long>(v));
  std::ostringstream out;
  out.precision(15);
  out << v;
  return out.str();
}

// The values of a numeric key worth trying: both ends and every listed value.
std::vector<double> accepted_values(const SetupKey& k) {
  std::vector<double> out{k.min, k.max};
  for (auto v : k.allowed_ints) out.push_back(static_cast<double>(v));
  return out;
}

// What the family's stack makes of a loaded configuration: its errors (empty = it runs).
std::vector<std::string> stack_errors(const Config& c) {
  const Drive& d = c.drives.at(0);
  std::vector<std::string> errors;
  switch (d.family) {
    case Family::kUc57: return uc57_driver::make_node_settings(c, c.buses.at(0), d, 100).errors;
    case Family::kAdamModbus: {
      // The master writes the set-up as registers; each must lie in the manual's range.
      const auto settings = adam_driver::settings_from_config(c, c.buses.at(0));
      for (const auto& [reg, words] : settings.drives.at(0).setup_writes) {
        if (reg == adam::address(adam::Reg::kRatedCurrent) && (words.at(0) < 10 || words.at(0) > 650)) {
          errors.push_back("0x000D rated current " + std::to_string(words.at(0)) + " outside 10..650 (manual §8.10)");
        }
        if (reg == adam::address(adam::Reg::kSubdivision)) {
          const std::uint32_t pulses =
              static_cast<std::uint32_t>(words.at(0)) | (static_cast<std::uint32_t>(words.at(1)) << 16);
          if (pulses < 200 || pulses > 1000000)
            errors.push_back("0x0024 subdivision " + std::to_string(pulses) + " outside 200..1000000 (§8.29)");
        }
      }
      return errors;
    }
    default: return errors;  // UIM342/UIM242 stacks send the schema's values as they are
  }
}

TEST(SetupAgreement, EveryValueTheSchemaAcceptsTheStackAccepts) {
  for (Family family : {Family::kUim342, Family::kUim242, Family::kUc57, Family::kAdamModbus}) {
    for (const SetupKey& k : setup_schema(family)) {
      if (k.type != SetupType::kInt && k.type != SetupType::kNumber) continue;
      for (double v : accepted_values(k)) {
        SCOPED_TRACE(std::string(to_string(family)) + " " + std::string(k.key) + " = " + text(v));
        const auto loaded = load_string(with_setup(family, std::string(k.key), text(v)), "agree.yaml");
        ASSERT_TRUE(loaded.ok()) << loaded.error_text();
        EXPECT_TRUE(stack_errors(*loaded.config).empty()) << stack_errors(*loaded.config).front();
      }
    }
  }
}

TEST(SetupAgreement, AValueBeyondTheSchemaIsRefusedAtLoadNamingTheKey) {
  for (Family family : {Family::kUim342, Family::kUim242, Family::kUc57, Family::kAdamModbus}) {
    for (const SetupKey& k : setup_schema(family)) {
      if (k.type != SetupType::kInt && k.type != SetupType::kNumber) continue;
      const double step = k.type == SetupType::kInt ? 1.0 : 0.1;
      for (double v : {k.min - step, k.max + step}) {
        SCOPED_TRACE(std::string(to_string(family)) + " " + std::string(k.key) + " = " + text(v));
        const auto loaded = load_string(with_setup(family, std::string(k.key), text(v)), "agree.yaml");
        ASSERT_FALSE(loaded.ok());
        EXPECT_NE(loaded.error_text().find(std::string(k.key)), std::string::npos) << loaded.error_text();
      }
    }
  }
}

TEST(SetupAgreement, TheManualsRangesAreTheSchemasRanges) {
  // UC57 2005h 1..25 × 0.1 A (§5.1); UIM342 MT[1] 5..80 × 0.1 A (§5.9); ADAM 0x000D 10..650 × 0.01 A (§8.10).
  EXPECT_DOUBLE_EQ(find_setup_key(Family::kUc57, "current_a")->max, 2.5);
  EXPECT_DOUBLE_EQ(find_setup_key(Family::kUim342, "current_a")->min, 0.5);
  EXPECT_DOUBLE_EQ(find_setup_key(Family::kAdamModbus, "current_a")->max, 6.5);
  EXPECT_DOUBLE_EQ(find_setup_key(Family::kAdamModbus, "pulses_per_revolution")->max, 1000000);
  const auto loaded = load_string(with_setup(Family::kUc57, "current_a", "2.5"), "a.yaml");
  ASSERT_TRUE(loaded.ok()) << loaded.error_text();
  const auto u =
      uc57_driver::make_node_settings(*loaded.config, loaded.config->buses[0], loaded.config->drives[0], 100);
  EXPECT_EQ(u.run_current, std::optional<std::uint16_t>(25));
}

}  // namespace
}  // namespace motion::config
