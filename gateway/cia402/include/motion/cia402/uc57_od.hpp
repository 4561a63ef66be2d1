// The ADAMPOWER UC57 object dictionary as data: every object the manual lists (§5 CiA 301
// communication table, §5.1 manufacturer objects 2000h-2FFFh, §5.2 CiA 402 objects), with what an
// SDO server needs (type size, access, range) and what a master needs (PDO flag, unit, default).
// Shared by the gateway master and the drive simulator.
//
// Printed values are kept; where the manual contradicts itself, the entry follows the choice
// documented in uc57_units.hpp ("Conflicts"). Objects the manual does not list (e.g. 605Ah,
// 1008h) are absent: an SDO server answers them with AccessError::kNoObject.
//
// Abort reasons are local (AccessError); the CiA 301 layer (gateway/canopen) maps them to wire
// abort codes.
//
// Thread contract: the table is immutable constexpr data; every function is pure and thread-safe.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string_view>

namespace motion::cia402::uc57 {

// CiA 301 basic data types, valued by their data-type object index (0002h ... 0007h).
enum class DataType : std::uint16_t {
  kInteger8 = 0x0002,
  kInteger16 = 0x0003,
  kInteger32 = 0x0004,
  kUnsigned8 = 0x0005,
  kUnsigned16 = 0x0006,
  kUnsigned32 = 0x0007,
};
[[nodiscard]] std::uint8_t size_bytes(DataType type);
[[nodiscard]] bool is_signed(DataType type);
[[nodiscard]] std::int64_t type_min(DataType type);
[[nodiscard]] std::int64_t type_max(DataType type);

// Manual attributes. kReadWriteStore = "RW/S": writable and stored to EEPROM by 2010h = 2 (or
// automatically when 200Ch = 0). kWriteOnly does not occur on the UC57; it exists for the server
// contract (and tests).
enum class Access : std::uint8_t { kReadOnly, kReadWrite, kReadWriteStore, kWriteOnly };
[[nodiscard]] bool readable(Access access);
[[nodiscard]] bool writable(Access access);

// Physical meaning of the raw integer.
enum class Unit : std::uint8_t {
  kNone,
  kBitField,
  kEnumerated,  // a code from a value list (see the description)
  kCobId,
  kMappingEntry,  // PDO mapping: index << 16 | subindex << 8 | length in bits
  kPulses,        // microsteps at the 2006h resolution
  kRpm,
  kRampSetting,  // 6083h/6084h/609Ah: printed "rps/s", used as ms (see uc57_units.hpp)
  kMilliseconds,
  kHundredMicroseconds,  // PDO inhibit time
  kDeciAmpereRms,        // 0.1 A RMS
  kPerMille,             // 0.1 %
};

struct OdEntry {
  std::uint16_t index = 0;
  std::uint8_t subindex = 0;
  std::string_view name;
  DataType type = DataType::kUnsigned8;
  Access access = Access::kReadOnly;
  bool pdo_mappable = false;
  std::int64_t min = 0;  // accepted write range, inclusive
  std::int64_t max = 0;
  std::int64_t default_value = 0;
  bool default_plus_node_id = false;  // the default is default_value + node-ID ("200h+Node-ID")
  Unit unit = Unit::kNone;
  // When not empty, the only values accepted (6060h: 0, 1, 3, 6); min/max still bound them.
  std::span<const std::int64_t> allowed_values;
};

// The whole dictionary, sorted by (index, subindex), unique.
[[nodiscard]] std::span<const OdEntry> object_dictionary();

[[nodiscard]] const OdEntry* find_entry(std::uint16_t index, std::uint8_t subindex);
[[nodiscard]] bool has_object(std::uint16_t index);
// All subindexes of one object, in order (empty when the object does not exist).
[[nodiscard]] std::span<const OdEntry> object_entries(std::uint16_t index);

// The power-on value of an entry on a node (COB-ID defaults depend on the node-ID; 2000h reports it).
[[nodiscard]] std::int64_t default_value(const OdEntry& entry, std::uint8_t node_id);

// Why an SDO access is refused (CiA 301 abort reasons, mapped to wire codes by gateway/canopen).
enum class AccessError : std::uint8_t {
  kNoObject,        // 0602 0000
  kNoSubindex,      // 0609 0011
  kReadOnly,        // 0601 0002: write to a read-only entry
  kWriteOnly,       // 0601 0001: read of a write-only entry
  kLengthMismatch,  // 0607 0010: data size differs from the type size
  kValueTooHigh,    // 0609 0031
  kValueTooLow,     // 0609 0032
  kInvalidValue,    // 0609 0030: inside min..max but not an allowed value
};
[[nodiscard]] std::string_view to_string(AccessError error);

// Simulator switches (the manual's ranges contradict each other, and its RO markings block the
// CiA 301 PDO remap procedure).
struct WritePolicy {
  bool check_range = true;
  bool check_length = true;
  // Make 14xxh/18xxh:01 (COB-ID) and 16xxh/1Axxh:00 (entry count) writable as in CiA 301.
  bool pdo_configuration_writable = false;
};

// Upload (read) check: the entry, or why it cannot be read.
struct Lookup {
  const OdEntry* entry = nullptr;
  std::optional<AccessError> error;
};
[[nodiscard]] Lookup check_read(std::uint16_t index, std::uint8_t subindex);
// Download (write) check of raw little-endian data. `data` is what the client sent (for an
// expedited transfer without size indication, pass the object's size bytes).
[[nodiscard]] Lookup check_write(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data,
                                 const WritePolicy& policy = {});
// Range/value check alone, for a value already decoded.
[[nodiscard]] std::optional<AccessError> check_value(const OdEntry& entry, std::int64_t value,
                                                     const WritePolicy& policy = {});

// Raw value codec for the OD's types (little-endian, CiA 301).
// decode: nullopt when data.size() != size_bytes(type).
[[nodiscard]] std::optional<std::int64_t> decode_value(DataType type, std::span<const std::uint8_t> data);
// encode: writes size_bytes(type) bytes; false when `out` is too small or the value does not fit.
bool encode_value(DataType type, std::int64_t value, std::span<std::uint8_t> out);

// PDO mapping entry (the manual's "60810020h" address form, UC57 §4.1 / CiA 301).
[[nodiscard]] constexpr std::uint32_t mapping_entry(std::uint16_t index, std::uint8_t subindex, std::uint8_t bits) {
  return (std::uint32_t{index} << 16) | (std::uint32_t{subindex} << 8) | bits;
}

// Frequently used indexes.
namespace index {
inline constexpr std::uint16_t kDeviceType = 0x1000;
inline constexpr std::uint16_t kErrorRegister = 0x1001;
inline constexpr std::uint16_t kPreDefinedErrorField = 0x1003;
inline constexpr std::uint16_t kEmcyCobId = 0x1014;
inline constexpr std::uint16_t kProducerHeartbeatTime = 0x1017;
inline constexpr std::uint16_t kIdentity = 0x1018;
inline constexpr std::uint16_t kSdoServer = 0x1200;
inline constexpr std::uint16_t kRpdoCommunication = 0x1400;  // + PDO number - 1
inline constexpr std::uint16_t kRpdoMapping = 0x1600;
inline constexpr std::uint16_t kTpdoCommunication = 0x1800;
inline constexpr std::uint16_t kTpdoMapping = 0x1A00;
inline constexpr std::uint16_t kNodeId = 0x2000;
inline constexpr std::uint16_t kMotorStatus = 0x2001;
inline constexpr std::uint16_t kInputLevels = 0x2003;
inline constexpr std::uint16_t kOutputStates = 0x2004;
inline constexpr std::uint16_t kRunCurrent = 0x2005;
inline constexpr std::uint16_t kMicrostepping = 0x2006;
inline constexpr std::uint16_t kStandstillCurrent = 0x2007;
inline constexpr std::uint16_t kNodeIdSetting = 0x2008;
inline constexpr std::uint16_t kBitRateSetting = 0x2009;
inline constexpr std::uint16_t kStopAtLimit = 0x200A;
inline constexpr std::uint16_t kControlMethod = 0x200B;
inline constexpr std::uint16_t kAutoStore = 0x200C;
inline constexpr std::uint16_t kStartSpeed = 0x200E;
inline constexpr std::uint16_t kMotorEnable = 0x200F;
inline constexpr std::uint16_t kParameterCommand = 0x2010;
inline constexpr std::uint16_t kFaultResetCommand = 0x2011;
inline constexpr std::uint16_t kZeroPosition = 0x2012;
inline constexpr std::uint16_t kIoConfiguration = 0x2030;
inline constexpr std::uint16_t kCurrentLoopKp = 0x2040;
inline constexpr std::uint16_t kCurrentLoopKi = 0x2041;
inline constexpr std::uint16_t kRunningTime = 0x2FF7;
inline constexpr std::uint16_t kFaultBits = 0x603F;
inline constexpr std::uint16_t kControlword = 0x6040;
inline constexpr std::uint16_t kStatusword = 0x6041;
inline constexpr std::uint16_t kHaltOption = 0x605D;
inline constexpr std::uint16_t kModesOfOperation = 0x6060;
inline constexpr std::uint16_t kModesOfOperationDisplay = 0x6061;
inline constexpr std::uint16_t kPositionActual = 0x6064;
inline constexpr std::uint16_t kVelocityActual = 0x606C;
inline constexpr std::uint16_t kTargetPosition = 0x607A;
inline constexpr std::uint16_t kHomeOffset = 0x607C;
inline constexpr std::uint16_t kProfileVelocity = 0x6081;
inline constexpr std::uint16_t kProfileAcceleration = 0x6083;
inline constexpr std::uint16_t kProfileDeceleration = 0x6084;
inline constexpr std::uint16_t kHomingMethod = 0x6098;
inline constexpr std::uint16_t kHomingSpeeds = 0x6099;  // :01 fast (search), :02 slow (locate)
inline constexpr std::uint16_t kHomingAcceleration = 0x609A;
inline constexpr std::uint16_t kDigitalInputs = 0x60FD;
inline constexpr std::uint16_t kTargetVelocity = 0x60FF;
}  // namespace index

}  // namespace motion::cia402::uc57
