// UIM242 instructions (host -> UIM2501/2502 gateway -> controller): the ASCII string protocol of
// EN/CN §2.2-§2.3 and §12.1-§12.3 (and the Summary), with one table that drives the encoder, the
// parser (used by the simulator) and the range checks.
//
// Shapes: `INS η;` (decimal), `INSx η;` (hex, bytes low first, even digit count), `INS;`, and the
// global `gINS[ η];` forms the gateway broadcasts (Summary). Each instruction including its `;`
// is at most 20 characters of 7-bit ASCII (§12.1).
//
// Decisions where the manuals are silent or disagree:
// * Addressing (not in EN/CN §3.1): the gateway keeps a sticky target selected by `ADR η;`
//   (EXT-2501 §3.3), ACK `AA η D0 FF`. Gateway instructions ADR, SET, BTR, BDR, ABC and g... never
//   reach a controller.
// * Hex forms (documented in EN/CN §12.3 only for these): only MCF, ICF, ENA (2 bytes) and SCF, STG
//   (register/value + index, 3 bytes); the byte count must match exactly, so the EN big-endian
//   examples without IDX are rejected. The encoder always prefers the decimal form where one
//   exists.
// * Error mapping: a form that does not exist (unknown mnemonic, value on FBK, `CUR;`, hex on
//   SPD, malformed number, > 20 characters, non-ASCII) is a syntax error (EE 65); a value outside
//   the documented set/range (CN #6 `CUR 81;`) is a value error (EE 66).
// * MMS/MMD accept 0..65535 (the 16-bit echo; 0 disables the non-linear jump, EN/CN §7.4). BTR accepts
//   0..15 (the manuals give no index table). `STO;` (EN only) is STO0 (assumed). `MDL;` (EN
//   Summary) asks the current target. POS/DIR (named in EN §2.3, §6.1, §7.6, never documented) are
//   not implemented.
// * Macros `{ ... }` (§2.3): the splitter strips the braces as they arrive and marks the
//   instructions received between them silent (no ACK); `{CUR 20; ...; };` thus yields exactly
//   the one ACK of the trailing null instruction.
// Thread contract: pure functions over values and an immutable table; InstructionSplitter is a
// single-threaded value type.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "motion/uim242/errors.hpp"

namespace motion::uim242 {

enum class Mnemonic : std::uint8_t {
  kNull,  // `;` alone: query desired status (#1), also the macro's trailing ACK
  // Controller instructions, EN/CN §12.3 (alphabetical).
  kACR,
  kBLC,
  kCUR,
  kDOU,
  kENA,
  kFBK,
  kICF,
  kMAC,
  kMCF,
  kMCS,
  kMDE,
  kMDL,
  kMMD,
  kMMS,
  kOFF,
  kORG,
  kQEC,
  kQER,
  kSCF,
  kSFB,
  kSPD,
  kSQT,
  kSTG,
  kSTO,
  kSTP,
  // Gateway instructions (Summary "network"; EXT-2501 §2-§3).
  kADR,  // select the target controller (sticky)
  kSET,  // burn a node id into the single connected controller
  kBTR,  // CAN bit-rate index of the network
  kBDR,  // gateway RS232 baud
  kABC,  // handshake: the gateway answers its greeting
  kREG,  // only as gREG: enumerate controllers
};

// Who executes an instruction.
enum class Target : std::uint8_t { kController, kGateway };

struct InstructionSpec {
  Mnemonic mnemonic;
  std::string_view text;  // three letters
  Target target;
  bool bare_form;     // `INS;` exists (a query or a value-less action)
  bool decimal_form;  // `INS η;` exists
  bool is_signed;     // the sign gives a direction
  std::int64_t min;   // decimal range, inclusive
  std::int64_t max;
  std::uint8_t hex_bytes;  // `INSx ...;` byte count, 0 = no hex form
  bool global_form;        // `gINS...;` exists
  std::string_view meaning;
};

[[nodiscard]] const InstructionSpec& spec(Mnemonic m) noexcept;
[[nodiscard]] std::span<const InstructionSpec> instruction_table() noexcept;
[[nodiscard]] std::string_view to_string(Mnemonic m) noexcept;
// "SPD" / "spd" -> SPD; the upper-casing rule of §12.1. nullopt for unknown mnemonics.
[[nodiscard]] std::optional<Mnemonic> parse_mnemonic(std::string_view three_letters) noexcept;

struct Instruction {
  Mnemonic mnemonic = Mnemonic::kNull;
  bool global = false;                // g... form: the gateway broadcasts it
  std::optional<std::int64_t> value;  // none: the bare `INS;` form
  bool hex = false;                   // value written as hex bytes, low byte first
  friend bool operator==(const Instruction&, const Instruction&) = default;
};

inline constexpr std::size_t kMaxInstructionChars = 20;  // including the `;` (§12.1)

// Checks form and range against the table: the error the controller would answer with
// (ErrorCode::kSyntaxError / value_error), or success.
[[nodiscard]] std::error_code validate(const Instruction& instruction) noexcept;

// The instruction as sent, terminator included ("SPD -1000;", "MCFx 34 12;", "gSPD 500;").
// Fails with CodecErrc for forms or values the controller would reject.
[[nodiscard]] Result<std::string> encode(const Instruction& instruction);
// Shorthands for the usual forms (always decimal).
[[nodiscard]] Result<std::string> encode_set(Mnemonic m, std::int64_t value);
[[nodiscard]] Result<std::string> encode_bare(Mnemonic m);
[[nodiscard]] Result<std::string> encode_global(Mnemonic m, std::optional<std::int64_t> value = std::nullopt);
// `ADR η;`: route the following instructions to controller η.
[[nodiscard]] Result<std::string> encode_select(int node_id);

// Parses one instruction: the text between two `;` (without the `;`), per EN/CN §1.6 and §12.1
// (filler between mnemonic and value, case-insensitive, sign, hex pairs; the exact rules are our
// reading of their examples). An empty/blank chunk is the null instruction. Errors are ErrorCode
// values.
[[nodiscard]] Result<Instruction> parse_instruction(std::string_view chunk);

// ---- Register-addressed instructions --------------------------------------------------------

// SCF suffix / IDX (EN/CN §8.6-§8.8 and every worked example: 2 = ATCONL, 3 = ATCONH).
enum class SensorRegister : std::uint8_t { kS12CON = 0, kS34CON = 1, kATCONL = 2, kATCONH = 3 };
struct ScfWrite {
  SensorRegister reg = SensorRegister::kS12CON;
  std::uint16_t value = 0;
  friend bool operator==(const ScfWrite&, const ScfWrite&) = default;
};
// Decimal η = register × 16 + suffix; hex bytes = low, high, IDX. nullopt for a suffix above 3.
[[nodiscard]] std::optional<ScfWrite> scf_write(const Instruction& scf) noexcept;
[[nodiscard]] Instruction make_scf(ScfWrite write) noexcept;  // decimal form (identical in EN and CN)

// STGx D0 D1 IDX: sampling interval of sensor port IDX (0..2 = S1..S3): 0 continuous, 1..60000 ms
// intermittent, above 60000 single (EN §8.3, #40).
struct StgWrite {
  std::uint8_t port = 0;
  std::uint16_t interval = 0;
  friend bool operator==(const StgWrite&, const StgWrite&) = default;
};
[[nodiscard]] std::optional<StgWrite> stg_write(const Instruction& stg) noexcept;
[[nodiscard]] Instruction make_stg(StgWrite write) noexcept;

// `ENAxFFFF;`: the hex value FFFF is outside ENA's range and means "read the auto-enable time" (#11).
[[nodiscard]] bool is_enable_timer_query(const Instruction& instruction) noexcept;

// ---- Incremental splitting of the host's byte stream (gateway / simulator side) --------------

struct InstructionChunk {
  std::string text;       // between two `;`, braces removed
  bool silent = false;    // received inside a `{ ... }` macro: no ACK (errors are still sent)
  bool oversize = false;  // the text overflowed kMaxPendingChars and was cut: a syntax error
};

// Bytes arrive in arbitrary pieces; a chunk is complete at its `;`. Text that never gets a `;`
// stays pending (not stated in the manuals: assumed no ACK, no error). A run longer than
// kMaxPendingChars without a `;` is discarded up to the next `;`, which then yields one oversize
// chunk (EE 65).
class InstructionSplitter {
 public:
  static constexpr std::size_t kMaxPendingChars = 64;
  std::vector<InstructionChunk> push(std::span<const std::uint8_t> bytes);
  std::vector<InstructionChunk> push(std::string_view text);
  [[nodiscard]] bool in_macro() const noexcept { return macro_; }
  void reset() noexcept;

 private:
  std::string pending_;
  bool macro_ = false;
  bool overflow_ = false;
};

}  // namespace motion::uim242
