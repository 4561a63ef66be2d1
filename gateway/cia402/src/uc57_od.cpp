#include "motion/cia402/uc57_od.hpp"

#include <algorithm>
#include <array>
#include <cstddef>

#include "motion/core/bytes.hpp"

namespace motion::cia402::uc57 {
namespace {

constexpr std::uint8_t type_size(DataType type) {
  switch (type) {
    case DataType::kInteger8:
    case DataType::kUnsigned8: return 1;
    case DataType::kInteger16:
    case DataType::kUnsigned16: return 2;
    case DataType::kInteger32:
    case DataType::kUnsigned32: return 4;
  }
  return 0;
}

constexpr bool type_is_signed(DataType type) {
  return type == DataType::kInteger8 || type == DataType::kInteger16 || type == DataType::kInteger32;
}

struct Range {
  std::int64_t min;
  std::int64_t max;
};

constexpr Range full(DataType type) {
  const int bits = 8 * type_size(type);
  if (type_is_signed(type)) return {-(std::int64_t{1} << (bits - 1)), (std::int64_t{1} << (bits - 1)) - 1};
  return {0, (std::int64_t{1} << bits) - 1};
}

constexpr auto U8 = DataType::kUnsigned8;
constexpr auto U16 = DataType::kUnsigned16;
constexpr auto U32 = DataType::kUnsigned32;
constexpr auto I8 = DataType::kInteger8;
constexpr auto I16 = DataType::kInteger16;
constexpr auto I32 = DataType::kInteger32;
constexpr auto RO = Access::kReadOnly;
constexpr auto RW = Access::kReadWrite;
constexpr auto RWS = Access::kReadWriteStore;
constexpr bool kPdo = true;
constexpr bool kNoPdo = false;

// Columns in the manual's order (Index, Sub, Name, Type, Attribute, PDO mapping, Default), then
// the accepted range and the unit.
constexpr OdEntry row(std::uint16_t index, std::uint8_t subindex, std::string_view name, DataType type, Access access,
                      bool pdo, std::int64_t default_value, Range range, Unit unit) {
  OdEntry entry;
  entry.index = index;
  entry.subindex = subindex;
  entry.name = name;
  entry.type = type;
  entry.access = access;
  entry.pdo_mappable = pdo;
  entry.default_value = default_value;
  entry.min = range.min;
  entry.max = range.max;
  entry.unit = unit;
  return entry;
}

constexpr OdEntry plus_node_id(OdEntry entry) {
  entry.default_plus_node_id = true;
  return entry;
}

constexpr OdEntry only(OdEntry entry, std::span<const std::int64_t> values) {
  entry.allowed_values = values;
  return entry;
}

// 6060h: UC57 §5.2 "0, 1, 3, 6" (the §4.2.3 "1/2/3" table is the misprint; see uc57_units.hpp).
constexpr std::int64_t kModeValues[] = {0, 1, 3, 6};

// One PDO's communication parameter object (manual §5 comm. table: 14xxh / 18xxh).
template <typename Sink>
constexpr void add_pdo_communication(Sink& add, std::uint16_t index, std::int64_t cob_id_base) {
  add(row(index, 0x00, "Highest subindex", U8, RO, kNoPdo, 5, full(U8), Unit::kNone));
  add(plus_node_id(row(index, 0x01, "COB-ID", U32, RO, kNoPdo, cob_id_base, full(U32), Unit::kCobId)));
  add(row(index, 0x02, "Transmission type", U8, RWS, kNoPdo, 0xFF, full(U8), Unit::kEnumerated));
  add(row(index, 0x03, "Inhibit time", U16, RWS, kNoPdo, 0, full(U16), Unit::kHundredMicroseconds));
  add(row(index, 0x05, "Event timer", U16, RWS, kNoPdo, 0, full(U16), Unit::kMilliseconds));
}

struct DefaultMapping {
  std::int64_t count;
  std::array<std::int64_t, 4> entries;
};

// One PDO's mapping parameter object (16xxh / 1Axxh): sub00 = entry count, sub01-04 entries.
template <typename Sink>
constexpr void add_pdo_mapping(Sink& add, std::uint16_t index, DefaultMapping defaults) {
  constexpr std::string_view kEntryNames[] = {"Mapped object 1", "Mapped object 2", "Mapped object 3",
                                              "Mapped object 4"};
  add(row(index, 0x00, "Number of mapped objects", U8, RO, kNoPdo, defaults.count, {0, 4}, Unit::kNone));
  for (std::size_t i = 0; i < defaults.entries.size(); ++i) {
    add(row(index, static_cast<std::uint8_t>(i + 1), kEntryNames[i], U32, RWS, kNoPdo, defaults.entries[i], full(U32),
            Unit::kMappingEntry));
  }
}

constexpr std::int64_t map(std::uint16_t index, std::uint8_t bits) { return mapping_entry(index, 0, bits); }

template <typename Sink>
constexpr void build_dictionary(Sink& add) {
  // --- CiA 301 communication area (manual §5, comm. table) ---
  add(row(0x1000, 0x00, "Device type", U32, RO, kNoPdo, 0x00040192, full(U32), Unit::kNone));
  add(row(0x1001, 0x00, "Error register", U8, RO, kNoPdo, 0, full(U8), Unit::kBitField));
  add(row(0x1003, 0x00, "Number of errors", U8, RO, kNoPdo, 8, {0, 8}, Unit::kNone));
  constexpr std::string_view kErrorNames[] = {"Error memory 1", "Error memory 2", "Error memory 3", "Error memory 4",
                                              "Error memory 5", "Error memory 6", "Error memory 7", "Error memory 8"};
  for (std::size_t i = 0; i < std::size(kErrorNames); ++i) {
    add(row(0x1003, static_cast<std::uint8_t>(i + 1), kErrorNames[i], U32, RO, kNoPdo, 0, full(U32), Unit::kNone));
  }
  add(row(0x1009, 0x00, "Hardware version", U16, RO, kNoPdo, 0x0100, full(U16), Unit::kNone));  // printed "1.0"
  add(row(0x100A, 0x00, "Software version", U16, RO, kNoPdo, 0x0100, full(U16), Unit::kNone));  // printed "1.0"
  add(plus_node_id(row(0x1014, 0x00, "EMCY COB-ID", U32, RW, kNoPdo, 0x80, full(U32), Unit::kCobId)));
  add(row(0x1017, 0x00, "Producer heartbeat time", U16, RWS, kNoPdo, 0, full(U16), Unit::kMilliseconds));
  add(row(0x1018, 0x00, "Identity: highest subindex", U8, RO, kNoPdo, 4, full(U8), Unit::kNone));
  add(row(0x1018, 0x01, "Vendor ID", U32, RO, kNoPdo, 0x00000322, full(U32), Unit::kNone));
  add(row(0x1018, 0x02, "Product code", U32, RO, kNoPdo, 0, full(U32), Unit::kNone));
  add(row(0x1018, 0x03, "Revision number", U32, RO, kNoPdo, 0, full(U32), Unit::kNone));
  add(row(0x1018, 0x04, "Serial number", U32, RO, kNoPdo, 0, full(U32), Unit::kNone));
  add(row(0x1200, 0x00, "SDO server: highest subindex", U8, RO, kNoPdo, 2, full(U8), Unit::kNone));
  add(plus_node_id(row(0x1200, 0x01, "SDO COB-ID client to server", U32, RO, kNoPdo, 0x600, full(U32), Unit::kCobId)));
  add(plus_node_id(row(0x1200, 0x02, "SDO COB-ID server to client", U32, RO, kNoPdo, 0x580, full(U32), Unit::kCobId)));

  constexpr std::array<std::int64_t, 4> kRpdoCobIdBase = {0x200, 0x300, 0x400, 0x500};
  constexpr std::array<std::int64_t, 4> kTpdoCobIdBase = {0x180, 0x280, 0x380, 0x480};
  constexpr std::array<DefaultMapping, 4> kRpdoMapping = {{
      {3, {map(0x6040, 16), map(0x60FF, 32), map(0x6060, 8), 0}},
      {2, {map(0x607A, 32), map(0x6081, 32), 0, 0}},
      {0, {0, 0, 0, 0}},
      {0, {0, 0, 0, 0}},
  }};
  constexpr std::array<DefaultMapping, 4> kTpdoMapping = {{
      {3, {map(0x6041, 16), map(0x60FD, 32), map(0x6061, 8), 0}},
      {2, {map(0x6064, 32), map(0x606C, 32), 0, 0}},  // count printed as 0 (conflict C-09)
      {0, {0, 0, 0, 0}},
      {0, {0, 0, 0, 0}},
  }};
  const auto object = [](std::uint16_t base, std::size_t pdo) { return static_cast<std::uint16_t>(base + pdo); };
  for (std::size_t pdo = 0; pdo < 4; ++pdo) add_pdo_communication(add, object(0x1400, pdo), kRpdoCobIdBase[pdo]);
  for (std::size_t pdo = 0; pdo < 4; ++pdo) add_pdo_mapping(add, object(0x1600, pdo), kRpdoMapping[pdo]);
  for (std::size_t pdo = 0; pdo < 4; ++pdo) add_pdo_communication(add, object(0x1800, pdo), kTpdoCobIdBase[pdo]);
  for (std::size_t pdo = 0; pdo < 4; ++pdo) add_pdo_mapping(add, object(0x1A00, pdo), kTpdoMapping[pdo]);

  // --- Manufacturer objects (manual §5.1) ---
  add(plus_node_id(row(0x2000, 0x00, "Node ID", U16, RO, kPdo, 0, {1, 127}, Unit::kNone)));
  add(row(0x2001, 0x00, "Motor status", U16, RO, kPdo, 0, {0, 1}, Unit::kEnumerated));
  add(row(0x2003, 0x00, "Input signal status", U16, RO, kPdo, 0, full(U16), Unit::kBitField));
  add(row(0x2004, 0x00, "Output signal status", U16, RO, kPdo, 0, full(U16), Unit::kBitField));
  add(row(0x2005, 0x00, "Set current", U16, RWS, kPdo, 15, {1, 25}, Unit::kDeciAmpereRms));
  add(row(0x2006, 0x00, "Subdivision setting", U16, RWS, kPdo, 13, {0, 15}, Unit::kEnumerated));
  add(row(0x2007, 0x00, "Lock current", U16, RWS, kPdo, 0, {0, 1}, Unit::kEnumerated));
  add(row(0x2008, 0x00, "Define node ID", U16, RWS, kPdo, 1, {1, 127}, Unit::kNone));
  add(row(0x2009, 0x00, "Bit rate setting", U16, RWS, kPdo, 2, {0, 5}, Unit::kEnumerated));
  add(row(0x200A, 0x00, "Stop at limit", U16, RWS, kPdo, 0, {0, 2}, Unit::kEnumerated));
  add(row(0x200B, 0x00, "Control method", U16, RWS, kPdo, 0, {0, 0}, Unit::kEnumerated));
  add(row(0x200C, 0x00, "Write RW/S values to EEPROM", U16, RW, kPdo, 1, {0, 1}, Unit::kEnumerated));
  add(row(0x200E, 0x00, "Start speed", U16, RW, kPdo, 10, {0, 1000}, Unit::kRpm));
  add(row(0x200F, 0x00, "Motor enable", U16, RW, kPdo, 2, {0, 2}, Unit::kEnumerated));
  add(row(0x2010, 0x00, "Register parameter setting", U16, RW, kPdo, 0, {0, 2}, Unit::kEnumerated));
  add(row(0x2011, 0x00, "Fault reset", U16, RW, kPdo, 0, {0, 1}, Unit::kEnumerated));  // conflict C-12
  add(row(0x2012, 0x00, "Zero current position", U16, RW, kPdo, 0, {0, 1}, Unit::kEnumerated));
  add(row(0x2030, 0x00, "I/O configuration: highest subindex", U16, RO, kNoPdo, 16, full(U16), Unit::kNone));
  add(row(0x2030, 0x01, "Input active level", U16, RWS, kPdo, 0, {0, 0x0007}, Unit::kBitField));
  add(row(0x2030, 0x02, "X0 function selection", U16, RWS, kPdo, 0, full(U16), Unit::kEnumerated));
  add(row(0x2030, 0x03, "X1 function selection", U16, RWS, kPdo, 0, full(U16), Unit::kEnumerated));
  add(row(0x2030, 0x04, "X2 function selection", U16, RWS, kPdo, 0, full(U16), Unit::kEnumerated));
  add(row(0x2030, 0x0C, "Output active level", U16, RWS, kPdo, 0, {0, 0x0003}, Unit::kBitField));
  add(row(0x2030, 0x0D, "Y0 function selection", U16, RWS, kPdo, 0, {0, 6}, Unit::kEnumerated));
  add(row(0x2030, 0x0E, "Y1 function selection", U16, RWS, kPdo, 0, {0, 6}, Unit::kEnumerated));
  add(row(0x2040, 0x00, "Current loop proportional coefficient", U16, RWS, kPdo, 220, {10, 500}, Unit::kPerMille));
  add(row(0x2041, 0x00, "Current loop integral gain", U16, RWS, kPdo, 3, {1, 500}, Unit::kPerMille));
  add(row(0x2FF7, 0x00, "Running time", U32, RO, kPdo, 0, full(U32), Unit::kNone));

  // --- CiA 402 objects (manual §5.2; conflicts with §4.2.x resolved per uc57_units.hpp) ---
  add(row(0x603F, 0x00, "Driver fault bits", U16, RO, kPdo, 0, full(U16), Unit::kBitField));
  add(row(0x6040, 0x00, "Controlword", U16, RW, kPdo, 0, full(U16), Unit::kBitField));
  add(row(0x6041, 0x00, "Statusword", U16, RO, kPdo, 0, full(U16), Unit::kBitField));
  add(row(0x605D, 0x00, "Halt control", I16, RW, kNoPdo, 0, {0, 1}, Unit::kEnumerated));
  add(only(row(0x6060, 0x00, "Modes of operation", I8, RW, kPdo, 0, {0, 6}, Unit::kEnumerated), kModeValues));
  add(row(0x6061, 0x00, "Modes of operation display", I8, RO, kPdo, 0, full(I8), Unit::kEnumerated));
  add(row(0x6064, 0x00, "Position actual value", I32, RO, kPdo, 0, full(I32), Unit::kPulses));
  add(row(0x606C, 0x00, "Velocity actual value", I32, RO, kPdo, 0, full(I32), Unit::kRpm));
  add(row(0x607A, 0x00, "Target position", I32, RW, kPdo, 5000, {-1000000, 1000000}, Unit::kPulses));
  add(row(0x607C, 0x00, "Home offset", I32, RW, kPdo, 0, {-1000000, 1000000}, Unit::kPulses));       // C-05
  add(row(0x6081, 0x00, "Profile velocity", U32, RW, kPdo, 60, {5, 1000}, Unit::kRpm));              // C-03
  add(row(0x6083, 0x00, "Profile acceleration", U32, RW, kPdo, 50, {1, 2000}, Unit::kRampSetting));  // C-02
  add(row(0x6084, 0x00, "Profile deceleration", U32, RW, kPdo, 50, {1, 2000}, Unit::kRampSetting));
  add(row(0x6098, 0x00, "Homing method", U8, RW, kPdo, 0, full(U8), Unit::kEnumerated));  // C-07
  add(row(0x6099, 0x00, "Homing speeds: highest subindex", U8, RO, kNoPdo, 2, full(U8), Unit::kNone));
  add(row(0x6099, 0x01, "Homing speed (search)", U32, RW, kPdo, 120, {1, 1000}, Unit::kRpm));
  add(row(0x6099, 0x02, "Homing speed (locate)", U32, RW, kPdo, 60, {1, 1000}, Unit::kRpm));
  add(row(0x609A, 0x00, "Homing acceleration", U32, RW, kPdo, 50, {1, 2000}, Unit::kRampSetting));
  add(row(0x60FD, 0x00, "Digital inputs", U32, RO, kPdo, 0, full(U32), Unit::kBitField));
  add(row(0x60FF, 0x00, "Target velocity", I32, RW, kPdo, 120, {-1000, 1000}, Unit::kRpm));  // C-04
}

struct CountingSink {
  std::size_t count = 0;
  constexpr void operator()(const OdEntry&) { ++count; }
};

constexpr std::size_t kEntryCount = [] {
  CountingSink sink;
  build_dictionary(sink);
  return sink.count;
}();

template <std::size_t N>
struct ArraySink {
  std::array<OdEntry, N> entries{};
  std::size_t count = 0;
  constexpr void operator()(const OdEntry& entry) { entries[count++] = entry; }
};

constexpr std::array<OdEntry, kEntryCount> kDictionary = [] {
  ArraySink<kEntryCount> sink;
  build_dictionary(sink);
  return sink.entries;
}();

constexpr bool key_less(const OdEntry& a, const OdEntry& b) {
  return a.index != b.index ? a.index < b.index : a.subindex < b.subindex;
}

static_assert(std::adjacent_find(kDictionary.begin(), kDictionary.end(),
                                 [](const OdEntry& a, const OdEntry& b) { return !key_less(a, b); }) ==
                  kDictionary.end(),
              "the object dictionary must be sorted by (index, subindex) without duplicates");

constexpr bool in_range(std::uint16_t index, std::uint16_t first, std::uint16_t last) {
  return index >= first && index <= last;
}

// The entries the manual marks RO although the CiA 301 remap procedure writes them (C-10).
bool is_pdo_configuration_guard(const OdEntry& entry) {
  const bool communication = in_range(entry.index, 0x1400, 0x1403) || in_range(entry.index, 0x1800, 0x1803);
  const bool mapping = in_range(entry.index, 0x1600, 0x1603) || in_range(entry.index, 0x1A00, 0x1A03);
  return (communication && entry.subindex == 0x01) || (mapping && entry.subindex == 0x00);
}

}  // namespace

std::uint8_t size_bytes(DataType type) { return type_size(type); }
bool is_signed(DataType type) { return type_is_signed(type); }
std::int64_t type_min(DataType type) { return full(type).min; }
std::int64_t type_max(DataType type) { return full(type).max; }

bool readable(Access access) { return access != Access::kWriteOnly; }
bool writable(Access access) { return access != Access::kReadOnly; }

std::span<const OdEntry> object_dictionary() { return kDictionary; }

std::span<const OdEntry> object_entries(std::uint16_t index) {
  // std::equal_range rather than std::ranges::equal_range: clang 14 (the fuzzing build) cannot
  // instantiate libstdc++ 12's ranges on this subrange.
  struct ByIndex {
    bool operator()(const OdEntry& e, std::uint16_t i) const { return e.index < i; }
    bool operator()(std::uint16_t i, const OdEntry& e) const { return i < e.index; }
  };
  const auto [first, last] = std::equal_range(kDictionary.begin(), kDictionary.end(), index, ByIndex{});
  return {first, last};
}

bool has_object(std::uint16_t index) { return !object_entries(index).empty(); }

const OdEntry* find_entry(std::uint16_t index, std::uint8_t subindex) {
  for (const OdEntry& entry : object_entries(index)) {
    if (entry.subindex == subindex) return &entry;
  }
  return nullptr;
}

std::int64_t default_value(const OdEntry& entry, std::uint8_t node_id) {
  return entry.default_value + (entry.default_plus_node_id ? node_id : 0);
}

std::string_view to_string(AccessError error) {
  switch (error) {
    case AccessError::kNoObject: return "object does not exist";
    case AccessError::kNoSubindex: return "subindex does not exist";
    case AccessError::kReadOnly: return "attempt to write a read-only object";
    case AccessError::kWriteOnly: return "attempt to read a write-only object";
    case AccessError::kLengthMismatch: return "data length does not match the object";
    case AccessError::kValueTooHigh: return "value too high";
    case AccessError::kValueTooLow: return "value too low";
    case AccessError::kInvalidValue: return "invalid value";
  }
  return "?";
}

namespace {

Lookup lookup(std::uint16_t index, std::uint8_t subindex) {
  if (!has_object(index)) return {nullptr, AccessError::kNoObject};
  const OdEntry* entry = find_entry(index, subindex);
  if (entry == nullptr) return {nullptr, AccessError::kNoSubindex};
  return {entry, std::nullopt};
}

}  // namespace

Lookup check_read(std::uint16_t index, std::uint8_t subindex) {
  Lookup result = lookup(index, subindex);
  if (result.entry != nullptr && !readable(result.entry->access)) result.error = AccessError::kWriteOnly;
  return result;
}

std::optional<AccessError> check_value(const OdEntry& entry, std::int64_t value, const WritePolicy& policy) {
  if (!policy.check_range) return std::nullopt;
  if (value > entry.max) return AccessError::kValueTooHigh;
  if (value < entry.min) return AccessError::kValueTooLow;
  if (!entry.allowed_values.empty() &&
      std::find(entry.allowed_values.begin(), entry.allowed_values.end(), value) == entry.allowed_values.end()) {
    return AccessError::kInvalidValue;
  }
  return std::nullopt;
}

Lookup check_write(std::uint16_t index, std::uint8_t subindex, std::span<const std::uint8_t> data,
                   const WritePolicy& policy) {
  Lookup result = lookup(index, subindex);
  if (result.entry == nullptr) return result;
  const OdEntry& entry = *result.entry;
  const bool unlocked = policy.pdo_configuration_writable && is_pdo_configuration_guard(entry);
  if (!writable(entry.access) && !unlocked) {
    result.error = AccessError::kReadOnly;
    return result;
  }
  const std::size_t size = size_bytes(entry.type);
  if (data.size() != size && policy.check_length) {
    result.error = AccessError::kLengthMismatch;
    return result;
  }
  // Without the length check, a longer payload is truncated and a shorter one zero-extended.
  std::array<std::uint8_t, 4> raw{};
  std::copy_n(data.begin(), std::min(size, data.size()), raw.begin());
  const auto value = decode_value(entry.type, std::span<const std::uint8_t>(raw.data(), size));
  result.error = check_value(entry, *value, policy);
  return result;
}

std::optional<std::int64_t> decode_value(DataType type, std::span<const std::uint8_t> data) {
  if (data.size() != size_bytes(type)) return std::nullopt;
  switch (type) {
    case DataType::kInteger8: return bytes::read_le<std::int8_t>(data);
    case DataType::kInteger16: return bytes::read_le<std::int16_t>(data);
    case DataType::kInteger32: return bytes::read_le<std::int32_t>(data);
    case DataType::kUnsigned8: return bytes::read_le<std::uint8_t>(data);
    case DataType::kUnsigned16: return bytes::read_le<std::uint16_t>(data);
    case DataType::kUnsigned32: return bytes::read_le<std::uint32_t>(data);
  }
  return std::nullopt;
}

bool encode_value(DataType type, std::int64_t value, std::span<std::uint8_t> out) {
  if (value < type_min(type) || value > type_max(type) || out.size() < size_bytes(type)) return false;
  switch (size_bytes(type)) {
    case 1: return bytes::write_le<std::uint8_t>(out, 0, static_cast<std::uint8_t>(value));
    case 2: return bytes::write_le<std::uint16_t>(out, 0, static_cast<std::uint16_t>(value));
    case 4: return bytes::write_le<std::uint32_t>(out, 0, static_cast<std::uint32_t>(value));
    default: return false;
  }
}

}  // namespace motion::cia402::uc57
