#include "motion/uim242/instruction.hpp"

#include <algorithm>
#include <array>
#include <cctype>

#include <fmt/format.h>

namespace motion::uim242 {
namespace {

constexpr std::int64_t kU16 = 65535;
constexpr std::int64_t kS32 = 2147483647;
constexpr std::int64_t kAccelerationMax = 65'000'000;  // pps/s in value mode (#15)

using T = Target;
// Order = Mnemonic order. Sources: EN/CN §12.3 entries (#n), Summary, EXT-2501 for the gateway.
constexpr std::array kTable{
    //            mnem           text   target         bare   dec    sign   min      max        hex glob
    InstructionSpec{Mnemonic::kNull, "", T::kController, true, false, false, 0, 0, 0, false,
                    "query desired status (#1)"},
    InstructionSpec{Mnemonic::kACR, "ACR", T::kController, true, true, false, 0, 99, 0, true,
                    "automatic current reduction: 0 off, 1 = 50 %, 2..99 % (#2, #3)"},
    InstructionSpec{Mnemonic::kBLC, "BLC", T::kController, true, true, false, 0, kU16, 0, false,
                    "backlash compensation, pulses (#4, #5)"},
    InstructionSpec{Mnemonic::kCUR, "CUR", T::kController, false, true, false, 0, 80, 0, true,
                    "phase current, tenths of an ampere (#6)"},
    InstructionSpec{Mnemonic::kDOU, "DOU", T::kController, true, true, false, 0, 1, 0, true,
                    "TTL output P4 level (#7, #8)"},
    InstructionSpec{Mnemonic::kENA, "ENA", T::kController, true, true, false, 1, 60000, 2, true,
                    "enable H-bridge; ENA η = auto-enable delay, ms (#9-#11)"},
    InstructionSpec{Mnemonic::kFBK, "FBK", T::kController, true, false, false, 0, 0, 0, false,
                    "read current motor status (#12)"},
    InstructionSpec{Mnemonic::kICF, "ICF", T::kController, true, true, false, 0, kU16, 2, false,
                    "initial configuration register ICFG, reboots (#13, #14)"},
    InstructionSpec{Mnemonic::kMAC, "MAC", T::kController, true, true, false, 1, kAccelerationMax, 0, false,
                    "acceleration, pps/s (AM 0) or ms (AM 1) (#15, #16)"},
    InstructionSpec{Mnemonic::kMCF, "MCF", T::kController, true, true, false, 0, kU16, 2, false,
                    "master configuration register MCFG (#17, #18)"},
    InstructionSpec{Mnemonic::kMCS, "MCS", T::kController, false, true, false, 1, 16, 0, true,
                    "micro-stepping 1, 2, 4, 8, 16 (#19)"},
    InstructionSpec{Mnemonic::kMDE, "MDE", T::kController, true, true, false, 1, kAccelerationMax, 0, false,
                    "deceleration, pps/s (DM 0) or ms (DM 1) (#20, #21)"},
    InstructionSpec{Mnemonic::kMDL, "MDL", T::kController, true, true, false, 5, 125, 0, false,
                    "model, modules, firmware of controller η (#22)"},
    InstructionSpec{Mnemonic::kMMD, "MMD", T::kController, true, true, false, 0, kU16, 0, false,
                    "maximum cessation speed, pps (#23, #24)"},
    InstructionSpec{Mnemonic::kMMS, "MMS", T::kController, true, true, false, 0, kU16, 0, false,
                    "maximum starting speed, pps (#25, #26)"},
    InstructionSpec{Mnemonic::kOFF, "OFF", T::kController, true, false, false, 0, 0, 0, true, "disable H-bridge (#27)"},
    InstructionSpec{Mnemonic::kORG, "ORG", T::kController, true, true, true, -kS32, kS32, 0, true,
                    "set the current position (#28, #29)"},
    InstructionSpec{Mnemonic::kQEC, "QEC", T::kController, true, true, true, -2'000'000'000, 2'000'000'000, 0, true,
                    "go to / read absolute encoder position (#30, #31)"},
    InstructionSpec{Mnemonic::kQER, "QER", T::kController, true, true, false, 0, 65000, 0, false,
                    "encoder lines per revolution (#32, #33)"},
    InstructionSpec{Mnemonic::kSCF, "SCF", T::kController, true, true, false, 0, 1048563, 3, false,
                    "sensor registers: register x 16 + suffix 0..3 (#34, #35)"},
    InstructionSpec{Mnemonic::kSFB, "SFB", T::kController, true, false, false, 0, 0, 0, false, "read sensors (#36)"},
    InstructionSpec{Mnemonic::kSPD, "SPD", T::kController, true, true, true, -kU16, kU16, 0, true,
                    "desired speed, pps, sign = direction (#37, #38)"},
    InstructionSpec{Mnemonic::kSQT, "SQT", T::kController, true, true, false, 0, kU16, 0, false,
                    "stall tolerance (#39, #40)"},
    InstructionSpec{Mnemonic::kSTG, "STG", T::kController, true, false, false, 0, 0, 3, false,
                    "sensor sampling modes (EN #40/#41, CN #41/#42)"},
    InstructionSpec{Mnemonic::kSTO, "STO", T::kController, true, true, false, 0, 7, 0, false,
                    "store / bind parameter group (EN #42/#43, CN #43)"},
    InstructionSpec{Mnemonic::kSTP, "STP", T::kController, true, true, true, -kS32, kS32, 0, true,
                    "relative displacement, pulses; 0 = leave PT (#44, #45)"},
    InstructionSpec{Mnemonic::kADR, "ADR", T::kGateway, false, true, false, 5, 125, 0, false,
                    "gateway: select target controller (EXT-2501 §3.3)"},
    InstructionSpec{Mnemonic::kSET, "SET", T::kGateway, false, true, false, 5, 125, 0, false,
                    "gateway: assign node id to the single controller (§3.1)"},
    InstructionSpec{Mnemonic::kBTR, "BTR", T::kGateway, true, true, false, 0, 15, 0, false,
                    "gateway: CAN bit-rate index (Summary)"},
    InstructionSpec{Mnemonic::kBDR, "BDR", T::kGateway, false, true, false, 9600, 115200, 0, false,
                    "gateway: RS232 baud (EXT-2501 §2.3)"},
    InstructionSpec{Mnemonic::kABC, "ABC", T::kGateway, true, false, false, 0, 0, 0, false,
                    "gateway: handshake, answered by the greeting (EXT-2501 §2.2)"},
    InstructionSpec{Mnemonic::kREG, "REG", T::kGateway, true, false, false, 0, 0, 0, true,
                    "gateway: enumerate controllers, only as gREG (EXT-2501 §3.4)"},
};

constexpr bool table_in_enum_order() {
  for (std::size_t i = 0; i < kTable.size(); ++i) {
    if (static_cast<std::size_t>(kTable[i].mnemonic) != i) return false;
  }
  return true;
}
static_assert(table_in_enum_order(), "kTable must list the mnemonics in enum order");

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }
bool is_letter(char c) { return (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z'); }
bool is_digit(char c) { return c >= '0' && c <= '9'; }
char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 'a' + 'A') : c; }
int hex_digit(char c) {
  if (is_digit(c)) return c - '0';
  const char u = upper(c);
  if (u >= 'A' && u <= 'F') return u - 'A' + 10;
  return -1;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_space(s.back())) s.remove_suffix(1);
  return s;
}

// Only MCS has a value set rather than a range (#19).
bool value_in_set(Mnemonic m, std::int64_t v) {
  if (m == Mnemonic::kMCS) return v == 1 || v == 2 || v == 4 || v == 8 || v == 16;
  return true;
}

// Index byte limits of the 3-byte hex forms (SCF IDX 0..3, STG IDX 0..2).
bool hex_index_valid(Mnemonic m, std::int64_t v) {
  const auto index = (v >> 16) & 0xFF;
  if (m == Mnemonic::kSCF) return index <= 3;
  if (m == Mnemonic::kSTG) return index <= 2;
  return true;
}

std::error_code validate_value(const InstructionSpec& s, const Instruction& in) {
  const std::int64_t v = *in.value;
  if (in.hex) {
    if (s.hex_bytes == 0) return ErrorCode::kSyntaxError;
    const std::int64_t limit = (std::int64_t{1} << (8 * s.hex_bytes)) - 1;
    if (v < 0 || v > limit) return ErrorCode::kSyntaxError;  // more bytes than the form has
    if (!hex_index_valid(s.mnemonic, v)) return ErrorCode::kValueError;
    if (s.mnemonic == Mnemonic::kENA && v != 0xFFFF && (v < s.min || v > s.max)) return ErrorCode::kValueError;
    return {};
  }
  if (!s.decimal_form) return ErrorCode::kSyntaxError;
  if (v < s.min || v > s.max || !value_in_set(s.mnemonic, v)) return ErrorCode::kValueError;
  if (s.mnemonic == Mnemonic::kSCF && (v & 0xF) > 3) return ErrorCode::kValueError;
  return {};
}

std::error_code to_codec_error(std::error_code e, const Instruction& in) {
  if (!e) return e;
  if (e == ErrorCode::kValueError) return CodecErrc::kValueOutOfRange;
  if (in.hex) return CodecErrc::kHexNotAllowed;
  return in.value ? CodecErrc::kValueNotAllowed : CodecErrc::kValueRequired;
}

}  // namespace

std::span<const InstructionSpec> instruction_table() noexcept { return kTable; }
const InstructionSpec& spec(Mnemonic m) noexcept { return kTable[static_cast<std::size_t>(m)]; }
std::string_view to_string(Mnemonic m) noexcept { return m == Mnemonic::kNull ? std::string_view{";"} : spec(m).text; }

std::optional<Mnemonic> parse_mnemonic(std::string_view three_letters) noexcept {
  if (three_letters.size() != 3) return std::nullopt;
  for (const auto& s : kTable) {
    if (s.text.size() == 3 && upper(three_letters[0]) == s.text[0] && upper(three_letters[1]) == s.text[1] &&
        upper(three_letters[2]) == s.text[2]) {
      return s.mnemonic;
    }
  }
  return std::nullopt;
}

std::error_code validate(const Instruction& in) noexcept {
  const auto& s = spec(in.mnemonic);
  if (in.global) {
    // Global forms take the same value as the controller instruction; REG/ENA/OFF/ORG none.
    if (!s.global_form) return ErrorCode::kSyntaxError;
  } else if (in.mnemonic == Mnemonic::kREG) {
    return ErrorCode::kSyntaxError;
  }
  if (!in.value) return s.bare_form ? std::error_code{} : std::error_code{ErrorCode::kSyntaxError};
  if (in.global && (in.mnemonic == Mnemonic::kOFF || in.mnemonic == Mnemonic::kREG)) return ErrorCode::kSyntaxError;
  return validate_value(s, in);
}

Result<std::string> encode(const Instruction& in) {
  const auto& s = spec(in.mnemonic);
  if (in.global && !s.global_form) return CodecErrc::kNotGlobal;
  if (const auto e = validate(in)) return to_codec_error(e, in);
  const std::string prefix = fmt::format("{}{}", in.global ? "g" : "", s.text);
  if (!in.value) return prefix + ";";
  if (!in.hex) return fmt::format("{} {};", prefix, *in.value);
  std::string text = prefix + "x";
  auto raw = static_cast<std::uint64_t>(*in.value);
  for (std::uint8_t i = 0; i < s.hex_bytes; ++i) {
    text += fmt::format(" {:02X}", raw & 0xFF);
    raw >>= 8;
  }
  return text + ";";
}

Result<std::string> encode_set(Mnemonic m, std::int64_t value) { return encode(Instruction{m, false, value, false}); }
Result<std::string> encode_bare(Mnemonic m) { return encode(Instruction{m, false, std::nullopt, false}); }
Result<std::string> encode_global(Mnemonic m, std::optional<std::int64_t> value) {
  return encode(Instruction{m, true, value, false});
}
Result<std::string> encode_select(int node_id) { return encode_set(Mnemonic::kADR, node_id); }

Result<Instruction> parse_instruction(std::string_view chunk) {
  const std::string_view text = trim(chunk);
  if (text.size() + 1 > kMaxInstructionChars) return ErrorCode::kSyntaxError;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte == 0 || byte > 127) return ErrorCode::kSyntaxError;
  }
  if (text.empty()) return Instruction{};

  Instruction in;
  std::size_t i = 0;
  // An optional g/G before three letters marks a global instruction (no controller mnemonic
  // starts with G, so this is unambiguous).
  if (text.size() >= 4 && upper(text[0]) == 'G' && is_letter(text[1]) && is_letter(text[2]) && is_letter(text[3])) {
    in.global = true;
    i = 1;
  }
  if (text.size() < i + 3) return ErrorCode::kSyntaxError;
  const auto mnemonic = parse_mnemonic(text.substr(i, 3));
  if (!mnemonic) return ErrorCode::kSyntaxError;
  in.mnemonic = *mnemonic;
  i += 3;
  // Further letters are part of a longer spelling (SETADR, gENABLE, gOFFLINE, gDOUT, SCFG) —
  // except the hex marker.
  while (i < text.size() && is_letter(text[i]) && upper(text[i]) != 'X') ++i;

  bool negative = false;
  bool signed_seen = false;
  for (; i < text.size(); ++i) {
    const char c = text[i];
    if (upper(c) == 'X' && !signed_seen) {
      // Hex: pairs of digits, spaces allowed between them, low byte first.
      std::uint64_t value = 0;
      int digits = 0;
      for (++i; i < text.size(); ++i) {
        if (is_space(text[i])) {
          if (digits % 2 != 0) return ErrorCode::kSyntaxError;  // a space inside a byte
          continue;
        }
        const int d = hex_digit(text[i]);
        if (d < 0 || digits >= 16) return ErrorCode::kSyntaxError;
        const int byte_index = digits / 2;
        const int shift = 8 * byte_index + (digits % 2 == 0 ? 4 : 0);
        value |= static_cast<std::uint64_t>(d) << shift;
        ++digits;
      }
      if (digits == 0 || digits % 2 != 0) return ErrorCode::kSyntaxError;  // §12.1: even count
      if (digits / 2 != spec(in.mnemonic).hex_bytes) return ErrorCode::kSyntaxError;
      in.hex = true;
      in.value = static_cast<std::int64_t>(value);
      break;
    }
    if (c == '+' || c == '-') {
      if (signed_seen) return ErrorCode::kSyntaxError;
      signed_seen = true;
      negative = c == '-';
      continue;
    }
    if (is_digit(c)) {
      std::int64_t value = 0;
      int digits = 0;
      for (; i < text.size() && is_digit(text[i]); ++i) {
        if (++digits > 12) return ErrorCode::kValueError;  // far beyond every range
        value = value * 10 + (text[i] - '0');
      }
      for (; i < text.size(); ++i) {
        if (!is_space(text[i])) return ErrorCode::kSyntaxError;  // η has no other characters inside
      }
      in.value = negative ? -value : value;
      if (negative && !spec(in.mnemonic).is_signed && value != 0) return ErrorCode::kValueError;
      break;
    }
    if (is_letter(c) || (signed_seen && !is_space(c))) return ErrorCode::kSyntaxError;
    // Anything else is filler: spaces, '=', ':', '%?&*' (EN/CN §1.6).
  }
  if (signed_seen && !in.value) return ErrorCode::kSyntaxError;
  if (const auto e = validate(in)) return e;
  return in;
}

std::optional<ScfWrite> scf_write(const Instruction& scf) noexcept {
  if (scf.mnemonic != Mnemonic::kSCF || !scf.value) return std::nullopt;
  const auto v = static_cast<std::uint64_t>(*scf.value);
  const std::uint64_t index = scf.hex ? (v >> 16) & 0xFF : v & 0xF;
  const std::uint64_t reg = scf.hex ? v & 0xFFFF : (v >> 4) & 0xFFFF;
  if (index > 3) return std::nullopt;
  return ScfWrite{static_cast<SensorRegister>(index), static_cast<std::uint16_t>(reg)};
}

Instruction make_scf(ScfWrite write) noexcept {
  return Instruction{Mnemonic::kSCF, false, std::int64_t{write.value} * 16 + static_cast<std::int64_t>(write.reg),
                     false};
}

std::optional<StgWrite> stg_write(const Instruction& stg) noexcept {
  if (stg.mnemonic != Mnemonic::kSTG || !stg.value || !stg.hex) return std::nullopt;
  const auto v = static_cast<std::uint64_t>(*stg.value);
  const auto port = (v >> 16) & 0xFF;
  if (port > 2) return std::nullopt;
  return StgWrite{static_cast<std::uint8_t>(port), static_cast<std::uint16_t>(v & 0xFFFF)};
}

Instruction make_stg(StgWrite write) noexcept {
  return Instruction{Mnemonic::kSTG, false, (std::int64_t{write.port} << 16) | write.interval, true};
}

bool is_enable_timer_query(const Instruction& in) noexcept {
  return in.mnemonic == Mnemonic::kENA && in.hex && in.value == 0xFFFF;
}

// ---- InstructionSplitter ----------------------------------------------------------------------

std::vector<InstructionChunk> InstructionSplitter::push(std::string_view text) {
  return push(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(text.data()), text.size()));
}

std::vector<InstructionChunk> InstructionSplitter::push(std::span<const std::uint8_t> bytes) {
  std::vector<InstructionChunk> out;
  for (const std::uint8_t b : bytes) {
    const char c = static_cast<char>(b);
    if (c == ';') {
      out.push_back(InstructionChunk{overflow_ ? std::string{} : pending_, macro_, overflow_});
      pending_.clear();
      overflow_ = false;
    } else if (c == '{') {
      macro_ = true;  // this and the following instructions produce no ACK (§2.3)
    } else if (c == '}') {
      macro_ = false;  // even without a trailing ';' (not stated in §2.3: assumed)
    } else if (!overflow_) {
      if (pending_.size() >= kMaxPendingChars) {
        overflow_ = true;  // drop up to the next ';' and answer one syntax error then
        pending_.clear();
      } else {
        pending_.push_back(c);
      }
    }
  }
  return out;
}

void InstructionSplitter::reset() noexcept {
  pending_.clear();
  macro_ = false;
  overflow_ = false;
}

}  // namespace motion::uim242
