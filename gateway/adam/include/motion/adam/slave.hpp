// Slave-side request handling for a simulated ADAM drive, pure apart from the RegisterBank the
// caller supplies: frame in → reply frame (or none) out. The simulator owns the register storage
// and the motion model; this file owns the Modbus rules:
//   * frames with a bad CRC or length, and broadcast reads, are discarded (no reply);
//   * frames for another unit are ignored (unit ≠ own and ≠ 0);
//   * unsupported functions → exception 0x01; malformed quantity/byte count → 0x03;
//   * the register map rules (registers.hpp check_request) → 0x02/0x03 before the bank is called;
//   * broadcasts (unit 0) are executed but never answered (§5); the restart command
//     0x00D4 = 0x0100 is never answered (§8.67);
//   * ExceptionMode::kSilent makes the slave send no exception frames at all (the real drive's
//     exception behaviour is not described in the manual's §6).
//
// Thread contract: serve() is reentrant; the RegisterBank is called on the caller's thread and
// its own thread-safety is the caller's business.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/adam/registers.hpp"
#include "motion/adam/rtu.hpp"

namespace motion::adam {

class RegisterBank {
 public:
  virtual ~RegisterBank() = default;
  // Fill `out` (out.size() registers from `start`); an exception code refuses the read.
  virtual std::optional<rtu::ExceptionCode> read(std::uint16_t start, std::span<std::uint16_t> out) = 0;
  // Store/act on `values` from `start` (one FC 0x06 or 0x10 request, already range-checked).
  virtual std::optional<rtu::ExceptionCode> write(std::uint16_t start, std::span<const std::uint16_t> values) = 0;
};

enum class ExceptionMode : std::uint8_t { kStandard, kSilent };

struct SlaveConfig {
  std::uint8_t unit = 1;  // own address = 0x0066 + SW − 1 (§8.37), 1…247
  AccessRules rules{};
  ExceptionMode exceptions = ExceptionMode::kStandard;
};

// What serve() did, for simulator logs and tests.
enum class ServeOutcome : std::uint8_t {
  kReplied,           // normal response in `reply`
  kException,         // exception response in `reply` (empty in silent mode)
  kExecutedSilently,  // broadcast or restart: executed, no reply by protocol
  kRejectedSilently,  // broadcast request refused (exception suppressed by the broadcast rule)
  kNotAddressed,      // another unit's frame
  kDiscarded,         // bad frame (frame_error says why)
};

struct ServeResult {
  ServeOutcome outcome = ServeOutcome::kDiscarded;
  std::vector<std::uint8_t> reply;      // empty: send nothing
  std::optional<rtu::Request> request;  // the decoded request, when there was one
  std::optional<rtu::ExceptionCode> exception;
  std::optional<rtu::FrameErrc> frame_error;
};

[[nodiscard]] ServeResult serve(std::span<const std::uint8_t> frame, const SlaveConfig& config, RegisterBank& bank);

}  // namespace motion::adam
