// PDO configuration through SDO (CiA 301 §7.5.2.35-38 and the remap procedure of the PDO
// mapping parameter description):
//   1. disable the PDO: COB-ID (sub01) with bit 31 set,
//   2. mapping sub00 := 0,
//   3. mapping sub01..N := entries,
//   4. mapping sub00 := N,
//   5. transmission type / inhibit time / event timer (sub02/03/05), while the PDO is still
//      disabled (CiA 301 forbids changing the inhibit time of an existing PDO),
//   6. enable: COB-ID with bit 31 clear,
// then reads every written object back and compares it with what was written.
//
// pdo_remap_steps() is pure; run_sdo_sequence() executes any step list through an SdoClient.
// Thread contract: as SdoClient (single-threaded, poll loop).
#pragma once

#include <cstdint>
#include <functional>
#include <optional>
#include <system_error>
#include <vector>

#include "motion/canopen/pdo.hpp"
#include "motion/canopen/sdo_client.hpp"
#include "motion/canopen/types.hpp"

namespace motion::canopen {

struct SdoStep {
  enum class Action : std::uint8_t {
    kWrite,   // download `value`
    kVerify,  // upload and compare with `value`
  };
  Action action = Action::kWrite;
  ObjectAddress object;
  std::vector<std::uint8_t> value;  // little-endian, the object's size
  // kVerify: bits compared. Both sides are read as unsigned little-endian numbers, so a server
  // that answers a U8 with 4 bytes (expedited without size) still matches.
  std::uint64_t compare_mask = ~std::uint64_t{0};
  friend bool operator==(const SdoStep&, const SdoStep&) = default;
};

struct SdoSequenceResult {
  std::error_code error;        // empty on success
  std::size_t failed_step = 0;  // index of the failing step (== step count on success)
};
using SdoSequenceCallback = std::function<void(const SdoSequenceResult&)>;

// Runs `steps` in order on `node`, stopping at the first failure (SDO error, or
// CanopenError::kReadBackMismatch for a verify step). The steps are queued one at a time, so
// other requests for the node may interleave.
void run_sdo_sequence(SdoClient& client, NodeId node, std::vector<SdoStep> steps, SdoSequenceCallback done);

struct PdoConfiguration {
  PdoDirection direction = PdoDirection::kReceive;
  std::uint16_t number = 1;  // 1..512 (RPDO1 = 1400h/1600h)
  std::uint32_t cob_id = 0;  // without bit 31; e.g. 201h for RPDO1 of node 1
  std::optional<std::uint8_t> transmission_type;
  std::optional<std::uint16_t> inhibit_time;  // 100 us units
  std::optional<std::uint16_t> event_timer;   // ms
  PdoMapping mapping;
};

// The write steps (and, with `verify`, the read-back steps after them); nullopt when the PDO
// number is out of range or the mapping exceeds 64 bits. The COB-ID read-back ignores bit 30
// (no RTR), which many devices force on for TPDOs.
[[nodiscard]] std::optional<std::vector<SdoStep>> pdo_remap_steps(const PdoConfiguration& config, bool verify = true);

// pdo_remap_steps() + run_sdo_sequence(); an invalid configuration completes at once with
// CanopenError::kInvalidArgument.
void configure_pdo(SdoClient& client, NodeId node, const PdoConfiguration& config, SdoSequenceCallback done,
                   bool verify = true);

}  // namespace motion::canopen
