// Fuzz targets: every decoder that reads bytes from outside the process (LCM messages, CAN
// frames, serial streams, configuration files), and the coordinator's command handling fed message
// sequences (coordinator_sequences: every request must end in exactly one terminal reply). Each
// is a function over arbitrary bytes that must neither crash, nor leak, nor allocate more than
// its input justifies. signed_messages runs the
// verifier path of signed requests and gateway commands (decode, then verify against keys). libFuzzer runs one per
// executable (libfuzzer_main.cpp, `tools/fuzz NAME`); test_fuzz_replay runs every target over
// its seed corpus (corpus/<name>/) and its regression inputs (regressions/<name>/).
//
// Thread contract: each call is independent; the targets keep no state between calls.
#pragma once

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>

namespace motion::fuzz {

int lcm_types(const std::uint8_t* data, std::size_t size);
int lcm_types_unchecked(const std::uint8_t* data, std::size_t size);
int uim342_can(const std::uint8_t* data, std::size_t size);
int uimessage_stream(const std::uint8_t* data, std::size_t size);
int canopen(const std::uint8_t* data, std::size_t size);
int adam_rtu(const std::uint8_t* data, std::size_t size);
int uim242_feedback(const std::uint8_t* data, std::size_t size);
int config_yaml(const std::uint8_t* data, std::size_t size);
int signed_messages(const std::uint8_t* data, std::size_t size);
int uc57_pdo(const std::uint8_t* data, std::size_t size);
int web_controls(const std::uint8_t* data, std::size_t size);
int coordinator_sequences(const std::uint8_t* data, std::size_t size);
int can_bus_sequences(const std::uint8_t* data, std::size_t size);

struct Target {
  const char* name;
  int (*run)(const std::uint8_t* data, std::size_t size);
};
// The targets tools/fuzz --smoke runs (lcm_types_unchecked is only the demonstration of what
// the bounded check prevents; it is expected to exceed the malloc limit).
inline constexpr Target kTargets[] = {
    {"lcm_types", &lcm_types},
    {"uim342_can", &uim342_can},
    {"uimessage_stream", &uimessage_stream},
    {"canopen", &canopen},
    {"adam_rtu", &adam_rtu},
    {"uim242_feedback", &uim242_feedback},
    {"config_yaml", &config_yaml},
    {"signed_messages", &signed_messages},
    {"uc57_pdo", &uc57_pdo},
    {"web_controls", &web_controls},
    {"coordinator_sequences", &coordinator_sequences},
    {"can_bus_sequences", &can_bus_sequences},
};

// Consumes the fuzzer's bytes front to back; reads past the end yield zeros / empty spans.
class Input {
 public:
  Input(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}
  [[nodiscard]] bool empty() const { return pos_ >= size_; }
  std::uint8_t byte() { return empty() ? 0 : data_[pos_++]; }
  std::uint16_t u16() { return static_cast<std::uint16_t>((byte() << 8) | byte()); }
  std::uint32_t u32() { return (static_cast<std::uint32_t>(u16()) << 16) | u16(); }
  std::span<const std::uint8_t> take(std::size_t n) {
    n = std::min(n, size_ - std::min(pos_, size_));
    const std::span<const std::uint8_t> out(data_ + pos_, n);
    pos_ += n;
    return out;
  }
  std::span<const std::uint8_t> rest() { return take(size_); }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t pos_ = 0;
};

}  // namespace motion::fuzz
