// Every example frame of the ADAM manual (§6, §8, transcribed; the manual's frames with a
// wrong CRC (OCR damage, typos) appear in their corrected form and, as printed, in kPrintedBadCrc), and
// derived vectors not in the manual (libmodbus-produced frames, status replies, broadcasts,
// exceptions). Each vector checks: CRC, typed decode against the manual's stated meaning, exact
// re-encoding, request/response pairing, and that the register map accepts the manual's own
// requests.
#include <gtest/gtest.h>

#include <optional>
#include <string_view>
#include <variant>
#include <vector>

#include "hex.hpp"
#include "motion/adam/registers.hpp"
#include "motion/adam/rtu.hpp"

namespace motion::adam {
namespace {

using test::hex;
using test::to_hex;

enum class Role { kRequest, kResponse, kEcho, kRequestNoReply };
enum class Shape { kReadRequest, kReadResponse, kWriteSingle, kWriteMultiple, kWriteMultipleAck };

struct ManualFrame {
  std::string_view ref;
  int seed_line;
  Role role;
  std::string_view hex;
  Shape shape;
  std::uint16_t address;                // start / register address (unused for read responses)
  std::uint16_t quantity;               // registers
  std::vector<std::uint16_t> values;    // register values (read response, writes)
  std::optional<std::int64_t> value32;  // the 32-bit value the manual states, low word first
};

struct PrintedFrame {
  std::string_view ref;
  int seed_line;
  std::string_view printed;
  std::string_view corrected;  // empty: unrecoverable (§8.4 status reply)
};

// clang-format off
// Transcribed from the manual's §8 examples (line numbers of the manual text); CRC-failing rows are
// corrected.
const std::vector<ManualFrame> kManualFrames = {
    {"§8.1", 238, Role::kRequest, "01 03 00 00 00 02 C4 0B", Shape::kReadRequest, 0x0000, 2, {}, std::nullopt},  // read 2 regs @0x0000 (printed with a stray 00 and CRC byte lost)
    {"§8.1", 240, Role::kResponse, "01 03 04 37 31 00 30 A5 9C", Shape::kReadResponse, 0x0000, 2, {0x3731, 0x0030}, std::nullopt},  // regs 0x3731,0x0030 (ASCII \"71\", NUL \"0\")
    {"§8.2", 258, Role::kRequest, "01 03 00 02 00 02 65 CB", Shape::kReadRequest, 0x0002, 2, {}, std::nullopt},  // read 2 reg @0x0002
    {"§8.2", 260, Role::kResponse, "01 03 04 30 31 00 35 64 EB", Shape::kReadResponse, 0x0000, 2, {0x3031, 0x0035}, std::nullopt},  // regs 0x3031,0x0035 (ASCII \"01\", NUL \"5\")
    {"§8.3", 276, Role::kRequest, "01 03 00 04 00 02 85 CA", Shape::kReadRequest, 0x0004, 2, {}, std::nullopt},  // read 2 reg @0x0004
    {"§8.3", 278, Role::kResponse, "01 03 04 00 00 00 00 FA 33", Shape::kReadResponse, 0x0000, 2, {0x0000, 0x0000}, 0},  // regs 0x0000,0x0000 → 32-bit 0x00000000 = 0
    {"§8.4", 315, Role::kRequest, "01 03 00 06 00 02 24 0A", Shape::kReadRequest, 0x0006, 2, {}, std::nullopt},  // read 2 reg @0x0006
    {"§8.5", 333, Role::kRequest, "01 03 00 08 00 01 05 C8", Shape::kReadRequest, 0x0008, 1, {}, std::nullopt},  // read 1 reg @0x0008
    {"§8.5", 335, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.5", 340, Role::kEcho, "01 06 00 08 00 0A 88 0F", Shape::kWriteSingle, 0x0008, 1, {0x000A}, std::nullopt},  // write 0x0008 := 0x000A (10) (10 × 10 ms = 100 ms)
    {"§8.6", 360, Role::kRequest, "01 03 00 09 00 01 54 08", Shape::kReadRequest, 0x0009, 1, {}, std::nullopt},  // read 1 reg @0x0009
    {"§8.6", 362, Role::kResponse, "01 03 02 00 0C B8 41", Shape::kReadResponse, 0x0000, 1, {0x000C}, std::nullopt},  // value 0x000C = 12 (12 → 115200 bit/s)
    {"§8.6", 367, Role::kEcho, "01 06 00 09 00 06 D9 CA", Shape::kWriteSingle, 0x0009, 1, {0x0006}, std::nullopt},  // write 0x0009 := 0x0006 (6) (6 → 9600 bit/s)
    {"§8.7", 389, Role::kRequest, "01 03 00 0A 00 01 A4 08", Shape::kReadRequest, 0x000A, 1, {}, std::nullopt},  // read 1 reg @0x000A
    {"§8.7", 391, Role::kResponse, "01 03 02 00 FA 38 07", Shape::kReadResponse, 0x0000, 1, {0x00FA}, std::nullopt},  // value 0x00FA = 250 (250 → 4 ms pulse delay)
    {"§8.7", 396, Role::kEcho, "01 06 00 0A 03 E8 A9 76", Shape::kWriteSingle, 0x000A, 1, {0x03E8}, std::nullopt},  // write 0x000A := 0x03E8 (1000) (1000 → 1 ms)
    {"§8.8", 412, Role::kRequest, "01 03 00 0B 00 01 F5 C8", Shape::kReadRequest, 0x000B, 1, {}, std::nullopt},  // read 1 reg @0x000B
    {"§8.8", 414, Role::kResponse, "01 03 02 00 C8 B9 D2", Shape::kReadResponse, 0x0000, 1, {0x00C8}, std::nullopt},  // value 0x00C8 = 200 (200 full steps = 360°)
    {"§8.8", 419, Role::kEcho, "01 06 00 0B 00 64 F9 E3", Shape::kWriteSingle, 0x000B, 1, {0x0064}, std::nullopt},  // write 0x000B := 0x0064 (100) (100 full steps = 180°)
    {"§8.9", 434, Role::kRequest, "01 03 00 0C 00 01 44 09", Shape::kReadRequest, 0x000C, 1, {}, std::nullopt},  // read 1 reg @0x000C
    {"§8.9", 436, Role::kResponse, "01 03 02 00 C8 B9 D2", Shape::kReadResponse, 0x0000, 1, {0x00C8}, std::nullopt},  // value 0x00C8 = 200 (text claims 100; bytes show 200)
    {"§8.9", 440, Role::kEcho, "01 06 00 0C 00 32 C8 1C", Shape::kWriteSingle, 0x000C, 1, {0x0032}, std::nullopt},  // write 0x000C := 0x0032 (50) (50 full steps = 90°)
    {"§8.10", 457, Role::kRequest, "01 03 00 0D 00 01 15 C9", Shape::kReadRequest, 0x000D, 1, {}, std::nullopt},  // read 1 reg @0x000D
    {"§8.10", 459, Role::kResponse, "01 03 02 00 64 B9 AF", Shape::kReadResponse, 0x0000, 1, {0x0064}, std::nullopt},  // value 0x0064 = 100 (1.00 A)
    {"§8.10", 463, Role::kEcho, "01 06 00 0D 01 F4 18 1E", Shape::kWriteSingle, 0x000D, 1, {0x01F4}, std::nullopt},  // write 0x000D := 0x01F4 (500) (5.00 A)
    {"§8.11", 483, Role::kRequest, "01 03 00 0E 00 01 E5 C9", Shape::kReadRequest, 0x000E, 1, {}, std::nullopt},  // read 1 reg @0x000E
    {"§8.11", 485, Role::kResponse, "01 03 02 19 19 72 1E", Shape::kReadResponse, 0x0000, 1, {0x1919}, std::nullopt},  // value 0x1919 = 6425 (min-run 25 % / idle 25 %)
    {"§8.11", 489, Role::kEcho, "01 06 00 0E 19 32 62 4C", Shape::kWriteSingle, 0x000E, 1, {0x1932}, std::nullopt},  // write 0x000E := 0x1932 (6450) (min-run 25 % / idle 50 %)
    {"§8.12", 508, Role::kEcho, "01 06 00 0F 09 C4 BE 0A", Shape::kWriteSingle, 0x000F, 1, {0x09C4}, std::nullopt},  // printed as the write frame, though the text says \"read\"; proper r...
    {"§8.12", 510, Role::kResponse, "01 03 02 03 E8 B8 FA", Shape::kReadResponse, 0x0000, 1, {0x03E8}, std::nullopt},  // value 0x03E8 = 1000 (1000 lines = 4000 counts/rev)
    {"§8.12", 514, Role::kEcho, "01 06 00 0F 09 C4 BE 0A", Shape::kWriteSingle, 0x000F, 1, {0x09C4}, std::nullopt},  // write 0x000F := 0x09C4 (2500) (2500 lines = 10000 counts/rev)
    {"§8.13", 531, Role::kRequest, "01 03 00 10 00 01 85 CF", Shape::kReadRequest, 0x0010, 1, {}, std::nullopt},  // read 1 reg @0x0010
    {"§8.13", 533, Role::kResponse, "01 03 02 00 14 B8 4B", Shape::kReadResponse, 0x0000, 1, {0x0014}, std::nullopt},  // value 0x0014 = 20 (20 full steps = 36°)
    {"§8.13", 537, Role::kEcho, "01 06 00 10 00 64 89 E4", Shape::kWriteSingle, 0x0010, 1, {0x0064}, std::nullopt},  // write 0x0010 := 0x0064 (100) (100 full steps = 180°)
    {"§8.14", 556, Role::kRequest, "01 03 00 11 00 01 D4 0F", Shape::kReadRequest, 0x0011, 1, {}, std::nullopt},  // read 1 reg @0x0011
    {"§8.14", 558, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.15", 588, Role::kRequest, "01 03 00 12 00 01 24 0F", Shape::kReadRequest, 0x0012, 1, {}, std::nullopt},  // read 1 reg @0x0012
    {"§8.15", 590, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.15", 594, Role::kEcho, "01 06 00 12 00 09 E9 C9", Shape::kWriteSingle, 0x0012, 1, {0x0009}, std::nullopt},  // write 0x0012 := 0x0009 (9) (bit0 (phase-open alarm prohibited) + bi...
    {"§8.16", 613, Role::kRequest, "01 03 00 15 00 01 95 CE", Shape::kReadRequest, 0x0015, 1, {}, std::nullopt},  // read 1 reg @0x0015
    {"§8.16", 615, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.17", 634, Role::kRequest, "01 03 00 16 00 01 65 CE", Shape::kReadRequest, 0x0016, 1, {}, std::nullopt},  // read 1 reg @0x0016
    {"§8.17", 636, Role::kResponse, "01 03 02 00 27 F8 5E", Shape::kReadResponse, 0x0000, 1, {0x0027}, std::nullopt},  // value 0x0027 = 39 (39 rpm)
    {"§8.17", 640, Role::kEcho, "01 06 00 16 00 00 68 0E", Shape::kWriteSingle, 0x0016, 1, {0x0000}, std::nullopt},  // write 0x0016 := 0x0000 (0) (clear peak)
    {"§8.18", 657, Role::kRequest, "01 03 00 17 00 01 34 0E", Shape::kReadRequest, 0x0017, 1, {}, std::nullopt},  // read 1 reg @0x0017
    {"§8.18", 659, Role::kResponse, "01 03 02 00 C8 B9 D2", Shape::kReadResponse, 0x0000, 1, {0x00C8}, std::nullopt},  // value 0x00C8 = 200
    {"§8.18", 663, Role::kEcho, "01 06 00 17 07 D0 3A 62", Shape::kWriteSingle, 0x0017, 1, {0x07D0}, std::nullopt},  // write 0x0017 := 0x07D0 (2000) (force open loop with a 1000-line enc...
    {"§8.19", 680, Role::kRequest, "01 03 00 19 00 01 55 CD", Shape::kReadRequest, 0x0019, 1, {}, std::nullopt},  // read 1 reg @0x0019
    {"§8.19", 682, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.20", 697, Role::kRequest, "01 03 00 1A 00 01 A5 CD", Shape::kReadRequest, 0x001A, 1, {}, std::nullopt},  // read 1 reg @0x001A
    {"§8.20", 699, Role::kResponse, "01 03 02 02 0D 78 E1", Shape::kReadResponse, 0x0000, 1, {0x020D}, std::nullopt},  // value 0x020D = 525 (525 mA)
    {"§8.21", 705, Role::kRequest, "01 03 00 1B 00 01 F4 0D", Shape::kReadRequest, 0x001B, 1, {}, std::nullopt},  // read 1 reg @0x001B
    {"§8.21", 707, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.21", 709, Role::kEcho, "01 06 00 1B 00 32 78 18", Shape::kWriteSingle, 0x001B, 1, {0x0032}, std::nullopt},  // write 0x001B := 0x0032 (50) (X0 filter 50 ms)
    {"§8.22", 726, Role::kRequest, "01 03 00 1C 00 01 45 CC", Shape::kReadRequest, 0x001C, 1, {}, std::nullopt},  // read 1 reg @0x001C
    {"§8.22", 728, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.22", 732, Role::kEcho, "01 06 00 1C 00 32 C9 D9", Shape::kWriteSingle, 0x001C, 1, {0x0032}, std::nullopt},  // write 0x001C := 0x0032 (50)
    {"§8.23", 749, Role::kRequest, "01 03 00 1D 00 01 14 0C", Shape::kReadRequest, 0x001D, 1, {}, std::nullopt},  // read 1 reg @0x001D
    {"§8.23", 751, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.23", 755, Role::kEcho, "01 06 00 1D 00 32 98 19", Shape::kWriteSingle, 0x001D, 1, {0x0032}, std::nullopt},  // write 0x001D := 0x0032 (50)
    {"§8.24", 772, Role::kRequest, "01 03 00 1E 00 01 E4 0C", Shape::kReadRequest, 0x001E, 1, {}, std::nullopt},  // read 1 reg @0x001E
    {"§8.24", 774, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.24", 778, Role::kEcho, "01 06 00 1E 00 96 69 A2", Shape::kWriteSingle, 0x001E, 1, {0x0096}, std::nullopt},  // write 0x001E := 0x0096 (150)
    {"§8.25", 795, Role::kRequest, "01 03 00 1F 00 01 B5 CC", Shape::kReadRequest, 0x001F, 1, {}, std::nullopt},  // read 1 reg @0x001F
    {"§8.25", 797, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.25", 801, Role::kEcho, "01 06 00 1F 00 C8 B9 9A", Shape::kWriteSingle, 0x001F, 1, {0x00C8}, std::nullopt},  // write 0x001F := 0x00C8 (200)
    {"§8.26", 818, Role::kRequest, "01 03 00 20 00 01 85 C0", Shape::kReadRequest, 0x0020, 1, {}, std::nullopt},  // read 1 reg @0x0020
    {"§8.26", 820, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.26", 824, Role::kEcho, "01 06 00 20 00 FA 08 43", Shape::kWriteSingle, 0x0020, 1, {0x00FA}, std::nullopt},  // write 0x0020 := 0x00FA (250)
    {"§8.27", 841, Role::kRequest, "01 03 00 21 00 01 D4 00", Shape::kReadRequest, 0x0021, 1, {}, std::nullopt},  // read 1 reg @0x0021
    {"§8.27", 843, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.27", 847, Role::kEcho, "01 06 00 21 01 2C D9 8D", Shape::kWriteSingle, 0x0021, 1, {0x012C}, std::nullopt},  // write 0x0021 := 0x012C (300)
    {"§8.28", 864, Role::kRequest, "01 03 00 22 00 01 24 00", Shape::kReadRequest, 0x0022, 1, {}, std::nullopt},  // read 1 reg @0x0022
    {"§8.28", 866, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.28", 870, Role::kEcho, "01 06 00 22 01 F4 29 D7", Shape::kWriteSingle, 0x0022, 1, {0x01F4}, std::nullopt},  // write 0x0022 := 0x01F4 (500)
    {"§8.29", 887, Role::kRequest, "01 03 00 24 00 02 84 00", Shape::kReadRequest, 0x0024, 2, {}, std::nullopt},  // read 2 reg @0x0024
    {"§8.29", 889, Role::kResponse, "01 03 04 0F A0 00 00 F9 05", Shape::kReadResponse, 0x0000, 2, {0x0FA0, 0x0000}, 4000},  // regs 0x0FA0,0x0000 → 32-bit 0x00000FA0 = 4000
    {"§8.29", 893, Role::kRequest, "01 10 00 24 00 02 04 27 10 00 00 FB 35", Shape::kWriteMultiple, 0x0024, 2, {0x2710, 0x0000}, 10000},  // write 0x0024..0x0025 := regs 0x2710,0x0000 → 0x00002710 = 10000
    {"§8.29", 895, Role::kResponse, "01 10 00 24 00 02 01 C3", Shape::kWriteMultipleAck, 0x0024, 2, {}, std::nullopt},  // ack: 2 regs written @0x0024
    {"§8.30", 914, Role::kRequest, "01 03 00 26 00 01 65 C1", Shape::kReadRequest, 0x0026, 1, {}, std::nullopt},  // read 1 reg @0x0026
    {"§8.30", 916, Role::kResponse, "01 03 02 01 72 39 F1", Shape::kReadResponse, 0x0000, 1, {0x0172}, std::nullopt},  // value 0x0172 = 370 (3.70 mH)
    {"§8.30", 920, Role::kEcho, "01 06 00 26 00 96 E8 6F", Shape::kWriteSingle, 0x0026, 1, {0x0096}, std::nullopt},  // write 0x0026 := 0x0096 (150) (1.50 mH)
    {"§8.31", 940, Role::kRequest, "01 03 00 27 00 01 34 01", Shape::kReadRequest, 0x0027, 1, {}, std::nullopt},  // read 1 reg @0x0027
    {"§8.31", 942, Role::kResponse, "01 03 02 00 3C B8 55", Shape::kReadResponse, 0x0000, 1, {0x003C}, std::nullopt},  // value 0x003C = 60 (0.60 Ω)
    {"§8.31", 946, Role::kEcho, "01 06 00 27 00 64 38 2A", Shape::kWriteSingle, 0x0027, 1, {0x0064}, std::nullopt},  // write 0x0027 := 0x0064 (100) (1.00 Ω)
    {"§8.32", 961, Role::kRequest, "01 03 00 44 00 01 C4 1F", Shape::kReadRequest, 0x0044, 1, {}, std::nullopt},  // read 1 reg @0x0044
    {"§8.32", 963, Role::kResponse, "01 03 02 09 75 7F F3", Shape::kReadResponse, 0x0000, 1, {0x0975}, std::nullopt},  // value 0x0975 = 2421 (24.21 V)
    {"§8.32", 965, Role::kEcho, "01 06 00 44 00 00 C9 DF", Shape::kWriteSingle, 0x0044, 1, {0x0000}, std::nullopt},  // write 0x0044 := 0x0000 (0) (clear)
    {"§8.33", 980, Role::kRequest, "01 03 00 45 00 01 95 DF", Shape::kReadRequest, 0x0045, 1, {}, std::nullopt},  // read 1 reg @0x0045
    {"§8.33", 982, Role::kResponse, "01 03 02 01 A0 B9 AC", Shape::kReadResponse, 0x0000, 1, {0x01A0}, std::nullopt},  // value 0x01A0 = 416 (4.16 A)
    {"§8.33", 987, Role::kEcho, "01 06 00 45 00 00 98 1F", Shape::kWriteSingle, 0x0045, 1, {0x0000}, std::nullopt},  // write 0x0045 := 0x0000 (0) (clear)
    {"§8.34", 1002, Role::kRequest, "01 03 00 46 00 01 65 DF", Shape::kReadRequest, 0x0046, 1, {}, std::nullopt},  // read 1 reg @0x0046
    {"§8.34", 1004, Role::kResponse, "01 03 02 00 C7 F9 D6", Shape::kReadResponse, 0x0000, 1, {0x00C7}, std::nullopt},  // value 0x00C7 = 199 (199 pulses)
    {"§8.34", 1009, Role::kEcho, "01 06 00 46 00 00 68 1F", Shape::kWriteSingle, 0x0046, 1, {0x0000}, std::nullopt},  // write 0x0046 := 0x0000 (0) (clear)
    {"§8.35", 1024, Role::kRequest, "01 03 00 47 00 01 34 1F", Shape::kReadRequest, 0x0047, 1, {}, std::nullopt},  // read 1 reg @0x0047
    {"§8.35", 1026, Role::kResponse, "01 03 02 00 38 B9 96", Shape::kReadResponse, 0x0000, 1, {0x0038}, std::nullopt},  // value 0x0038 = 56 (56 pulses)
    {"§8.35", 1031, Role::kEcho, "01 06 00 47 00 00 39 DF", Shape::kWriteSingle, 0x0047, 1, {0x0000}, std::nullopt},  // write 0x0047 := 0x0000 (0) (clear)
    {"§8.36", 1046, Role::kRequest, "01 03 00 48 00 01 04 1C", Shape::kReadRequest, 0x0048, 1, {}, std::nullopt},  // read 1 reg @0x0048
    {"§8.36", 1048, Role::kResponse, "01 03 02 09 4C BF E1", Shape::kReadResponse, 0x0000, 1, {0x094C}, std::nullopt},  // value 0x094C = 2380 (23.80 V)
    {"§8.36", 1053, Role::kEcho, "01 06 00 48 00 00 09 DC", Shape::kWriteSingle, 0x0048, 1, {0x0000}, std::nullopt},  // write 0x0048 := 0x0000 (0) (clear)
    {"§8.37", 1068, Role::kRequest, "01 03 00 66 00 01 64 15", Shape::kReadRequest, 0x0066, 1, {}, std::nullopt},  // read 1 reg @0x0066
    {"§8.37", 1070, Role::kResponse, "01 03 02 00 01 79 84", Shape::kReadResponse, 0x0000, 1, {0x0001}, std::nullopt},  // value 0x0001 = 1
    {"§8.37", 1074, Role::kEcho, "01 06 00 66 00 02 E8 14", Shape::kWriteSingle, 0x0066, 1, {0x0002}, std::nullopt},  // write 0x0066 := 0x0002 (2) (printed as one Request/Response frame f...
    {"§8.38", 1089, Role::kRequest, "01 03 00 6B 00 01 F5 D6", Shape::kReadRequest, 0x006B, 1, {}, std::nullopt},  // read 1 reg @0x006B
    {"§8.38", 1091, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.38", 1095, Role::kEcho, "01 06 00 6B 00 01 39 D6", Shape::kWriteSingle, 0x006B, 1, {0x0001}, std::nullopt},  // write 0x006B := 0x0001 (1) (1 = CCW)
    {"§8.39", 1125, Role::kEcho, "01 06 00 6C 00 04 48 14", Shape::kWriteSingle, 0x006C, 1, {0x0004}, std::nullopt},  // write 0x006C := 0x0004 (4) (toggle X2 polarity (bit 2))
    {"§8.40", 1142, Role::kRequest, "01 03 00 96 00 01 64 26", Shape::kReadRequest, 0x0096, 1, {}, std::nullopt},  // read 1 reg @0x0096
    {"§8.40", 1144, Role::kResponse, "01 03 02 00 32 39 91", Shape::kReadResponse, 0x0000, 1, {0x0032}, std::nullopt},  // value 0x0032 = 50
    {"§8.40", 1148, Role::kEcho, "01 06 00 96 00 00 69 E6", Shape::kWriteSingle, 0x0096, 1, {0x0000}, std::nullopt},  // write 0x0096 := 0x0000 (0) (0 rpm)
    {"§8.41", 1163, Role::kRequest, "01 03 00 97 00 01 35 E6", Shape::kReadRequest, 0x0097, 1, {}, std::nullopt},  // read 1 reg @0x0097
    {"§8.41", 1165, Role::kResponse, "01 03 02 00 32 39 91", Shape::kReadResponse, 0x0000, 1, {0x0032}, std::nullopt},  // value 0x0032 = 50
    {"§8.41", 1169, Role::kEcho, "01 06 00 97 00 00 38 26", Shape::kWriteSingle, 0x0097, 1, {0x0000}, std::nullopt},  // write 0x0097 := 0x0000 (0) (0 rpm)
    {"§8.42", 1184, Role::kRequest, "01 03 00 98 00 01 05 E5", Shape::kReadRequest, 0x0098, 1, {}, std::nullopt},  // read 1 reg @0x0098
    {"§8.42", 1186, Role::kResponse, "01 03 02 00 78 B8 66", Shape::kReadResponse, 0x0000, 1, {0x0078}, std::nullopt},  // value 0x0078 = 120
    {"§8.42", 1190, Role::kEcho, "01 06 00 98 00 C8 09 B3", Shape::kWriteSingle, 0x0098, 1, {0x00C8}, std::nullopt},  // write 0x0098 := 0x00C8 (200) (200 ms)
    {"§8.43", 1205, Role::kRequest, "01 03 00 99 00 01 54 25", Shape::kReadRequest, 0x0099, 1, {}, std::nullopt},  // read 1 reg @0x0099
    {"§8.43", 1207, Role::kResponse, "01 03 02 00 78 B8 66", Shape::kReadResponse, 0x0000, 1, {0x0078}, std::nullopt},  // value 0x0078 = 120
    {"§8.43", 1211, Role::kEcho, "01 06 00 99 01 2C 59 A8", Shape::kWriteSingle, 0x0099, 1, {0x012C}, std::nullopt},  // write 0x0099 := 0x012C (300) (300 ms)
    {"§8.44", 1226, Role::kRequest, "01 03 00 9A 00 01 A4 25", Shape::kReadRequest, 0x009A, 1, {}, std::nullopt},  // read 1 reg @0x009A
    {"§8.44", 1228, Role::kResponse, "01 03 02 01 2C B8 09", Shape::kReadResponse, 0x0000, 1, {0x012C}, std::nullopt},  // value 0x012C = 300
    {"§8.44", 1232, Role::kEcho, "01 06 00 9A 00 C8 A8 73", Shape::kWriteSingle, 0x009A, 1, {0x00C8}, std::nullopt},  // write 0x009A := 0x00C8 (200) (200 rpm)
    {"§8.45", 1247, Role::kRequest, "01 03 00 6E 00 02 A5 D6", Shape::kReadRequest, 0x006E, 2, {}, std::nullopt},  // read 2 reg @0x006E
    {"§8.45", 1249, Role::kResponse, "01 03 04 00 00 80 00 9B F3", Shape::kReadResponse, 0x0000, 2, {0x0000, 0x8000}, -2147483648},  // regs 0x0000,0x8000 → 32-bit 0x80000000 = -2147483648
    {"§8.45", 1253, Role::kRequest, "01 10 00 6E 00 02 04 D8 F0 FF FF 4F 28", Shape::kWriteMultiple, 0x006E, 2, {0xD8F0, 0xFFFF}, -10000},  // write 0x006E..0x006F := regs 0xD8F0,0xFFFF → 0xFFFFD8F0 = -10000
    {"§8.45", 1255, Role::kResponse, "01 10 00 6E 00 02 20 15", Shape::kWriteMultipleAck, 0x006E, 2, {}, std::nullopt},  // ack: 2 regs written @0x006E
    {"§8.46", 1270, Role::kRequest, "01 03 00 70 00 02 C5 D0", Shape::kReadRequest, 0x0070, 2, {}, std::nullopt},  // read 2 reg @0x0070
    {"§8.46", 1272, Role::kResponse, "01 03 04 FF FF 7F FF 9A 67", Shape::kReadResponse, 0x0000, 2, {0xFFFF, 0x7FFF}, 2147483647},  // regs 0xFFFF,0x7FFF → 32-bit 0x7FFFFFFF = 2147483647
    {"§8.46", 1276, Role::kRequest, "01 10 00 70 00 02 04 27 10 00 00 FF FA", Shape::kWriteMultiple, 0x0070, 2, {0x2710, 0x0000}, 10000},  // intended: write 0x0070..0x0071 := 10000 (byte count 04 missing)
    {"§8.46", 1278, Role::kResponse, "01 10 00 70 00 02 40 13", Shape::kWriteMultipleAck, 0x0070, 2, {}, std::nullopt},  // ack: 2 regs written @0x0070
    {"§8.47", 1302, Role::kRequest, "01 03 00 9B 00 01 F5 E5", Shape::kReadRequest, 0x009B, 1, {}, std::nullopt},  // read 1 reg @0x009B
    {"§8.47", 1304, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.47", 1314, Role::kEcho, "01 06 00 9B 30 31 2D F1", Shape::kWriteSingle, 0x009B, 1, {0x3031}, std::nullopt},  // write 0x009B := 0x3031 (12337) (neg limit on X0, pos limit on X1, b...
    {"§8.48", 1340, Role::kEcho, "01 06 00 9C 00 32 C8 31", Shape::kWriteSingle, 0x009C, 1, {0x0032}, std::nullopt},  // write 0x009C := 0x0032 (50) (home on X2, enabled, high-level active...
    {"§8.48", 1342, Role::kRequest, "01 03 00 9C 00 01 44 24", Shape::kReadRequest, 0x009C, 1, {}, std::nullopt},  // read 1 reg @0x009C
    {"§8.48", 1344, Role::kResponse, "01 03 02 00 32 39 91", Shape::kReadResponse, 0x0000, 1, {0x0032}, std::nullopt},  // value 0x0032 = 50
    {"§8.48", 1350, Role::kEcho, "01 06 00 9D 01 F4 18 33", Shape::kWriteSingle, 0x009D, 1, {0x01F4}, std::nullopt},  // write 0x009D := 0x01F4 (500) (after homing go 500 pulses CW, then r...
    {"§8.48", 1352, Role::kRequest, "01 03 00 9D 00 01 15 E4", Shape::kReadRequest, 0x009D, 1, {}, std::nullopt},  // read 1 reg @0x009D
    {"§8.48", 1354, Role::kResponse, "01 03 02 01 F4 B8 53", Shape::kReadResponse, 0x0000, 1, {0x01F4}, std::nullopt},  // value 0x01F4 = 500
    {"§8.48", 1360, Role::kEcho, "01 06 00 AE 00 02 69 EA", Shape::kWriteSingle, 0x00AE, 1, {0x0002}, std::nullopt},  // write 0x00AE := 0x0002 (2) (Y1 = home-done output)
    {"§8.48", 1362, Role::kRequest, "01 03 00 AE 00 01 E5 EB", Shape::kReadRequest, 0x00AE, 1, {}, std::nullopt},  // read 1 reg @0x00AE
    {"§8.48", 1364, Role::kResponse, "01 03 02 00 02 39 85", Shape::kReadResponse, 0x0000, 1, {0x0002}, std::nullopt},  // value 0x0002 = 2
    {"§8.48", 1371, Role::kEcho, "01 06 00 C9 B2 2A AC 8B", Shape::kWriteSingle, 0x00C9, 1, {0xB22A}, std::nullopt},  // write 0x00C9 := 0xB22A (45610) (reverse, 200 rpm, immediate stop, r...
    {"§8.49", 1388, Role::kEcho, "01 06 00 9E 01 32 68 61", Shape::kWriteSingle, 0x009E, 1, {0x0132}, std::nullopt},  // write 0x009E := 0x0132 (306) (mode 1 (collision homing), torque lev...
    {"§8.49", 1390, Role::kRequest, "01 03 00 9E 00 01 E5 E4", Shape::kReadRequest, 0x009E, 1, {}, std::nullopt},  // read 1 reg @0x009E
    {"§8.49", 1392, Role::kResponse, "01 03 02 01 32 38 01", Shape::kReadResponse, 0x0000, 1, {0x0132}, std::nullopt},  // value 0x0132 = 306
    {"§8.49", 1400, Role::kEcho, "01 06 00 CB 03 E9 39 4A", Shape::kWriteSingle, 0x00CB, 1, {0x03E9}, std::nullopt},  // write 0x00CB := 0x03E9 (1001) (forward, offset 500 pulses, run)
    {"§8.50", 1421, Role::kRequest, "01 03 00 9F 00 01 B4 24", Shape::kReadRequest, 0x009F, 1, {}, std::nullopt},  // read 1 reg @0x009F
    {"§8.50", 1423, Role::kResponse, "01 03 02 00 03 F8 45", Shape::kReadResponse, 0x0000, 1, {0x0003}, std::nullopt},  // intended value 3 (I/O mode)
    {"§8.50", 1427, Role::kEcho, "01 06 00 9F 00 02 38 25", Shape::kWriteSingle, 0x009F, 1, {0x0002}, std::nullopt},  // write 0x009F := 0x0002 (2) (2 = pulse+direction)
    {"§8.51", 1473, Role::kEcho, "01 06 00 A5 00 00 99 E9", Shape::kWriteSingle, 0x00A5, 1, {0x0000}, std::nullopt},  // write 0x00A5 := 0x0000 (0) (cancel alarm-output function)
    {"§8.51", 1475, Role::kEcho, "01 06 00 A6 00 00 69 E9", Shape::kWriteSingle, 0x00A6, 1, {0x0000}, std::nullopt},  // write 0x00A6 := 0x0000 (0) (cancel running-output function)
    {"§8.51", 1477, Role::kEcho, "01 06 00 A7 00 00 38 29", Shape::kWriteSingle, 0x00A7, 1, {0x0000}, std::nullopt},  // write 0x00A7 := 0x0000 (0) (cancel in-position-output function)
    {"§8.51", 1481, Role::kEcho, "01 06 00 A0 00 43 C8 19", Shape::kWriteSingle, 0x00A0, 1, {0x0043}, std::nullopt},  // write 0x00A0 := 0x0043 (67) (turn on Y0, Y1, Y6)
    {"§8.51", 1485, Role::kEcho, "01 06 00 A1 00 FF 98 68", Shape::kWriteSingle, 0x00A1, 1, {0x00FF}, std::nullopt},  // write 0x00A1 := 0x00FF (255) (turn off all)
    {"§8.51", 1489, Role::kRequest, "01 03 00 A2 00 01 25 E8", Shape::kReadRequest, 0x00A2, 1, {}, std::nullopt},  // read 1 reg @0x00A2
    {"§8.51", 1491, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // intended value 0x0000 (all outputs off)
    {"§8.51", 1498, Role::kEcho, "01 06 00 A5 00 00 99 E9", Shape::kWriteSingle, 0x00A5, 1, {0x0000}, std::nullopt},  // write 0x00A5 := 0x0000 (0)
    {"§8.51", 1500, Role::kEcho, "01 06 00 A6 00 00 69 E9", Shape::kWriteSingle, 0x00A6, 1, {0x0000}, std::nullopt},  // write 0x00A6 := 0x0000 (0)
    {"§8.51", 1502, Role::kEcho, "01 06 00 A7 00 00 38 29", Shape::kWriteSingle, 0x00A7, 1, {0x0000}, std::nullopt},  // write 0x00A7 := 0x0000 (0)
    {"§8.51", 1507, Role::kEcho, "01 06 00 A6 01 01 A9 B9", Shape::kWriteSingle, 0x00A6, 1, {0x0101}, std::nullopt},  // write 0x00A6 := 0x0101 (257) (Y0 as running output, off while runni...
    {"§8.52", 1527, Role::kRequest, "01 03 00 A3 00 01 74 28", Shape::kReadRequest, 0x00A3, 1, {}, std::nullopt},  // read 1 reg @0x00A3
    {"§8.52", 1529, Role::kResponse, "01 03 02 00 03 F8 45", Shape::kReadResponse, 0x0000, 1, {0x0003}, std::nullopt},  // value 0x0003 = 3 (current alarm 3 = under-voltage)
    {"§8.52", 1533, Role::kEcho, "01 06 00 A4 00 00 C8 29", Shape::kWriteSingle, 0x00A4, 1, {0x0000}, std::nullopt},  // write 0x00A4 := 0x0000 (0) (clear alarms)
    {"§8.53", 1545, Role::kRequest, "01 10 00 A8 00 02 04 FE 0C 7F FF 69 EA", Shape::kWriteMultiple, 0x00A8, 2, {0xFE0C, 0x7FFF}, 2147483148},  // write 0x00A8..0x00A9 := regs 0xFE0C,0x7FFF → 0x7FFFFE0C = 214748314...
    {"§8.53", 1547, Role::kResponse, "01 10 00 A8 00 02 C0 28", Shape::kWriteMultipleAck, 0x00A8, 2, {}, std::nullopt},  // ack: 2 regs written @0x00A8
    {"§8.53", 1551, Role::kRequest, "01 10 00 C2 00 02 04 13 88 80 00 9B 48", Shape::kWriteMultiple, 0x00C2, 2, {0x1388, 0x8000}, -2147478648},  // write 0x00C2..0x00C3 := regs 0x1388,0x8000 → 0x80001388 = -21474786...
    {"§8.53", 1553, Role::kResponse, "01 10 00 C2 00 02 E0 34", Shape::kWriteMultipleAck, 0x00C2, 2, {}, std::nullopt},  // ack: 2 regs written @0x00C2
    {"§8.54", 1585, Role::kRequest, "01 10 01 F4 00 02 04 63 BF 00 00 DF 28", Shape::kWriteMultiple, 0x01F4, 2, {0x63BF, 0x0000}, 25535},  // write 0x01F4..0x01F5 := regs 0x63BF,0x0000 → 0x000063BF = 25535
    {"§8.54", 1586, Role::kRequest, "01 10 01 F6 00 02 04 CA F9 FF FF 9F 08", Shape::kWriteMultiple, 0x01F6, 2, {0xCAF9, 0xFFFF}, -13575},  // write 0x01F6..0x01F7 := regs 0xCAF9,0xFFFF → 0xFFFFCAF9 = -13575
    {"§8.54", 1591, Role::kRequest, "01 10 01 F4 00 30 60 63 BF 00 00 CA F9 FF FF 30 40 00 00 D4 21 FF FF 5F F3 00 00 B5 ED FF FF 30 39 00 00 FD A8 FF FF 16 03 00 00 F2 13 FF FF 64 23 00 00 9B DD FF FF 05 41 00 00 E8 90 FF FF DB FB 00 00 74 E1 FF FF 0A 05 00 00 F6 19 FF FF 09 29 00 00 EA 20 FF FF 21 BB 00 00 FA AB FF FF 3D 13 00 00 E9 FD FF FF 14 91", Shape::kWriteMultiple, 0x01F4, 48, {0x63BF, 0x0000, 0xCAF9, 0xFFFF, 0x3040, 0x0000, 0xD421, 0xFFFF, 0x5FF3, 0x0000, 0xB5ED, 0xFFFF, 0x3039, 0x0000, 0xFDA8, 0xFFFF, 0x1603, 0x0000, 0xF213, 0xFFFF, 0x6423, 0x0000, 0x9BDD, 0xFFFF, 0x0541, 0x0000, 0xE890, 0xFFFF, 0xDBFB, 0x0000, 0x74E1, 0xFFFF, 0x0A05, 0x0000, 0xF619, 0xFFFF, 0x0929, 0x0000, 0xEA20, 0xFFFF, 0x21BB, 0x0000, 0xFAAB, 0xFFFF, 0x3D13, 0x0000, 0xE9FD, 0xFFFF}, std::nullopt},  // write 48 regs @0x01F4 (reg 500..547): all 24 table entries, low wor...
    {"§8.54", 1603, Role::kEcho, "01 06 00 AA 00 18 A9 E0", Shape::kWriteSingle, 0x00AA, 1, {0x0018}, std::nullopt},  // write 0x00AA := 0x0018 (24) (24 entries)
    {"§8.54", 1609, Role::kEcho, "01 06 00 AB 00 15 39 E5", Shape::kWriteSingle, 0x00AB, 1, {0x0015}, std::nullopt},  // write 0x00AB := 0x0015 (21) (start at entry 21 (−1365))
    {"§8.54", 1616, Role::kEcho, "01 06 00 AC 00 C8 48 7D", Shape::kWriteSingle, 0x00AC, 1, {0x00C8}, std::nullopt},  // write 0x00AC := 0x00C8 (200) (entry 0 at reg 300+200 = 500)
    {"§8.54", 1624, Role::kEcho, "01 06 00 DD 10 01 D5 F0", Shape::kWriteSingle, 0x00DD, 1, {0x1001}, std::nullopt},  // write 0x00DD := 0x1001 (4097) (absolute, pointer −1 after each run)
    {"§8.55", 1639, Role::kEcho, "01 06 00 AD 4C 95 EC 84", Shape::kWriteSingle, 0x00AD, 1, {0x4C95}, std::nullopt},  // write 0x00AD := 0x4C95 (19605) (e-stop: X3 low-active, X4 high-acti...
    {"§8.55", 1641, Role::kRequest, "01 03 00 AD 00 01 15 EB", Shape::kReadRequest, 0x00AD, 1, {}, std::nullopt},  // read 1 reg @0x00AD
    {"§8.55", 1643, Role::kResponse, "01 03 02 4C 95 4C EB", Shape::kReadResponse, 0x0000, 1, {0x4C95}, std::nullopt},  // value 0x4C95 = 19605
    {"§8.56", 1669, Role::kEcho, "01 06 00 AF 14 0A 36 EC", Shape::kWriteSingle, 0x00AF, 1, {0x140A}, std::nullopt},  // write 0x00AF := 0x140A (5130) (X0, level, high-active, both dirs, 1...
    {"§8.56", 1673, Role::kEcho, "01 06 00 B3 00 2F 39 F1", Shape::kWriteSingle, 0x00B3, 1, {0x002F}, std::nullopt},  // write 0x00B3 := 0x002F (47) (override to 47 rpm)
    {"§8.56", 1679, Role::kEcho, "01 06 00 B0 2E 0A 15 8A", Shape::kWriteSingle, 0x00B0, 1, {0x2E0A}, std::nullopt},  // write 0x00B0 := 0x2E0A (11786) (port code 2 (+16 from 0x00B4 bit15 ...
    {"§8.56", 1681, Role::kEcho, "01 06 00 B4 83 E8 A8 92", Shape::kWriteSingle, 0x00B4, 1, {0x83E8}, std::nullopt},  // write 0x00B4 := 0x83E8 (33768) (bit15 = port high bit, 1000 rpm)
    {"§8.57", 1700, Role::kRequest, "01 10 00 B6 00 02 04 00 C8 15 00 F7 9F", Shape::kWriteMultiple, 0x00B6, 2, {0x00C8, 0x1500}, 352321736},  // write 0x00B6..0x00B7 := regs 0x00C8,0x1500 → 0x150000C8 = 352321736...
    {"§8.57", 1702, Role::kResponse, "01 10 00 B6 00 02 A0 2E", Shape::kWriteMultipleAck, 0x00B6, 2, {}, std::nullopt},  // ack: 2 regs written @0x00B6
    {"§8.57", 1704, Role::kRequest, "01 03 00 B6 00 02 25 ED", Shape::kReadRequest, 0x00B6, 2, {}, std::nullopt},  // read 2 reg @0x00B6
    {"§8.57", 1706, Role::kResponse, "01 03 04 00 C8 15 00 75 5D", Shape::kReadResponse, 0x0000, 2, {0x00C8, 0x1500}, 352321736},  // intended: regs 0x00C8,0x1500 → 0x150000C8
    {"§8.58", 1730, Role::kRequest, "01 10 00 BA 00 02 04 2C 18 00 00 F0 33", Shape::kWriteMultiple, 0x00BA, 2, {0x2C18, 0x0000}, 11288},  // write 0x00BA..0x00BB := regs 0x2C18,0x0000 → 0x00002C18 = 11288 (gr...
    {"§8.58", 1732, Role::kResponse, "01 10 00 BA 00 02 60 2D", Shape::kWriteMultipleAck, 0x00BA, 2, {}, std::nullopt},  // ack: 2 regs written @0x00BA
    {"§8.58", 1734, Role::kRequest, "01 03 00 BA 00 02 E5 EE", Shape::kReadRequest, 0x00BA, 2, {}, std::nullopt},  // read 2 reg @0x00BA
    {"§8.58", 1736, Role::kResponse, "01 03 04 2C 18 00 00 72 A4", Shape::kReadResponse, 0x0000, 2, {0x2C18, 0x0000}, 11288},  // regs 0x2C18,0x0000 → 32-bit 0x00002C18 = 11288
    {"§8.59", 1753, Role::kRequest, "01 03 00 BE 00 01 E4 2E", Shape::kReadRequest, 0x00BE, 1, {}, std::nullopt},  // read 1 reg @0x00BE
    {"§8.59", 1755, Role::kResponse, "01 03 02 00 00 B8 44", Shape::kReadResponse, 0x0000, 1, {0x0000}, std::nullopt},  // value 0x0000 = 0
    {"§8.59", 1759, Role::kEcho, "01 06 00 BE FF FB E9 9D", Shape::kWriteSingle, 0x00BE, 1, {0xFFFB}, std::nullopt},  // write 0x00BE := 0xFFFB (65531) (−5)
    {"§8.60", 1778, Role::kRequest, "01 03 00 BF 00 01 B5 EE", Shape::kReadRequest, 0x00BF, 1, {}, std::nullopt},  // read 1 reg @0x00BF
    {"§8.60", 1780, Role::kResponse, "01 03 02 00 64 B9 AF", Shape::kReadResponse, 0x0000, 1, {0x0064}, std::nullopt},  // value 0x0064 = 100
    {"§8.60", 1784, Role::kEcho, "01 06 00 BF 03 E8 B8 90", Shape::kWriteSingle, 0x00BF, 1, {0x03E8}, std::nullopt},  // write 0x00BF := 0x03E8 (1000) (Kp 10.00)
    {"§8.61", 1801, Role::kRequest, "01 03 00 29 00 01 55 C2", Shape::kReadRequest, 0x0029, 1, {}, std::nullopt},  // read 1 reg @0x0029
    {"§8.61", 1803, Role::kResponse, "01 03 02 00 64 B9 AF", Shape::kReadResponse, 0x0000, 1, {0x0064}, std::nullopt},  // value 0x0064 = 100
    {"§8.61", 1807, Role::kEcho, "01 06 00 29 00 0A D8 05", Shape::kWriteSingle, 0x0029, 1, {0x000A}, std::nullopt},  // write 0x0029 := 0x000A (10)
    {"§8.62", 1826, Role::kRequest, "01 03 00 C0 00 01 84 36", Shape::kReadRequest, 0x00C0, 1, {}, std::nullopt},  // read 1 reg @0x00C0
    {"§8.62", 1828, Role::kResponse, "01 03 02 00 64 B9 AF", Shape::kReadResponse, 0x0000, 1, {0x0064}, std::nullopt},  // value 0x0064 = 100
    {"§8.62", 1832, Role::kEcho, "01 06 00 C0 01 F4 89 E1", Shape::kWriteSingle, 0x00C0, 1, {0x01F4}, std::nullopt},  // write 0x00C0 := 0x01F4 (500) (5.00)
    {"§8.63a", 1849, Role::kRequest, "01 03 00 C1 00 01 D5 F6", Shape::kReadRequest, 0x00C1, 1, {}, std::nullopt},  // read 1 reg @0x00C1
    {"§8.63a", 1851, Role::kResponse, "01 03 02 03 E8 B8 FA", Shape::kReadResponse, 0x0000, 1, {0x03E8}, std::nullopt},  // value 0x03E8 = 1000
    {"§8.63a", 1855, Role::kEcho, "01 06 00 C1 00 64 D9 DD", Shape::kWriteSingle, 0x00C1, 1, {0x0064}, std::nullopt},  // write 0x00C1 := 0x0064 (100) (1.00)
    {"§8.63b", 1870, Role::kRequest, "01 03 00 D6 00 02 25 F3", Shape::kReadRequest, 0x00D6, 2, {}, std::nullopt},  // read 2 reg @0x00D6
    {"§8.63b", 1872, Role::kResponse, "01 03 04 00 00 00 00 FA 33", Shape::kReadResponse, 0x0000, 2, {0x0000, 0x0000}, 0},  // regs 0x0000,0x0000 → 32-bit 0x00000000 = 0
    {"§8.64", 1887, Role::kRequest, "01 03 00 D8 00 02 44 30", Shape::kReadRequest, 0x00D8, 2, {}, std::nullopt},  // read 2 reg @0x00D8
    {"§8.64", 1889, Role::kResponse, "01 03 04 75 30 00 00 E0 30", Shape::kReadResponse, 0x0000, 2, {0x7530, 0x0000}, 30000},  // regs 0x7530,0x0000 → 32-bit 0x00007530 = 30000 (300.00 rpm)
    {"§8.64", 1893, Role::kRequest, "01 10 00 D8 00 02 04 C3 50 00 00 C3 00", Shape::kWriteMultiple, 0x00D8, 2, {0xC350, 0x0000}, 50000},  // write 0x00D8..0x00D9 := regs 0xC350,0x0000 → 0x0000C350 = 50000 (50...
    {"§8.64", 1895, Role::kResponse, "01 10 00 D8 00 02 C1 F3", Shape::kWriteMultipleAck, 0x00D8, 2, {}, std::nullopt},  // ack: 2 regs written @0x00D8
    {"§8.65①", 1916, Role::kEcho, "01 06 00 C8 01 01 C8 64", Shape::kWriteSingle, 0x00C8, 1, {0x0101}, std::nullopt},  // write 0x00C8 := 0x0101 (257) (257 = run reverse)
    {"§8.65②", 1935, Role::kEcho, "01 06 00 CA 0C 81 6C 94", Shape::kWriteSingle, 0x00CA, 1, {0x0C81}, std::nullopt},  // write 0x00CA := 0x0C81 (3201) (CW, 50 rpm, decel-stop mode, start)
    {"§8.65③", 1950, Role::kRequest, "01 10 00 CC 00 02 04 E7 00 FF FF C8 AE", Shape::kWriteMultiple, 0x00CC, 2, {0xE700, 0xFFFF}, -6400},  // write 0x00CC..0x00CD := regs 0xE700,0xFFFF → 0xFFFFE700 = -6400 (re...
    {"§8.65③", 1952, Role::kResponse, "01 10 00 CC 00 02 81 F7", Shape::kWriteMultipleAck, 0x00CC, 2, {}, std::nullopt},  // ack: 2 regs written @0x00CC
    {"§8.65④", 1967, Role::kRequest, "01 10 00 CE 00 02 04 D8 F0 FF FF 45 50", Shape::kWriteMultiple, 0x00CE, 2, {0xD8F0, 0xFFFF}, -10000},  // write 0x00CE..0x00CF := regs 0xD8F0,0xFFFF → 0xFFFFD8F0 = -10000 (1...
    {"§8.65④", 1969, Role::kResponse, "01 10 00 CE 00 02 20 37", Shape::kWriteMultipleAck, 0x00CE, 2, {}, std::nullopt},  // ack: 2 regs written @0x00CE
    {"§8.65⑤", 1984, Role::kRequest, "01 10 00 DE 00 02 04 13 88 00 00 FB D1", Shape::kWriteMultiple, 0x00DE, 2, {0x1388, 0x0000}, 5000},  // write 0x00DE..0x00DF := regs 0x1388,0x0000 → 0x00001388 = 5000 (500...
    {"§8.65⑤", 1986, Role::kResponse, "01 10 00 DE 00 02 21 F2", Shape::kWriteMultipleAck, 0x00DE, 2, {}, std::nullopt},  // ack: 2 regs written @0x00DE
    {"§8.65⑥", 2001, Role::kRequest, "01 10 00 D0 00 02 04 27 10 00 00 F5 82", Shape::kWriteMultiple, 0x00D0, 2, {0x2710, 0x0000}, 10000},  // write 0x00D0..0x00D1 := regs 0x2710,0x0000 → 0x00002710 = 10000 (go...
    {"§8.65⑥", 2003, Role::kResponse, "01 10 00 D0 00 02 40 31", Shape::kWriteMultipleAck, 0x00D0, 2, {}, std::nullopt},  // ack: 2 regs written @0x00D0
    {"§8.65⑦", 2018, Role::kRequest, "01 10 00 E8 00 02 04 E0 C0 FF FF CA 0D", Shape::kWriteMultiple, 0x00E8, 2, {0xE0C0, 0xFFFF}, -8000},  // write 0x00E8..0x00E9 := regs 0xE0C0,0xFFFF → 0xFFFFE0C0 = -8000 (go...
    {"§8.65⑦", 2020, Role::kResponse, "01 10 00 E8 00 02 C1 FC", Shape::kWriteMultipleAck, 0x00E8, 2, {}, std::nullopt},  // ack: 2 regs written @0x00E8
    {"§8.66", 2035, Role::kRequest, "01 10 00 D2 00 02 04 03 E8 00 00 FF 5A", Shape::kWriteMultiple, 0x00D2, 2, {0x03E8, 0x0000}, 1000},  // write 0x00D2..0x00D3 := regs 0x03E8,0x0000 → 0x000003E8 = 1000 (pos...
    {"§8.66", 2037, Role::kResponse, "01 10 00 D2 00 02 E1 F1", Shape::kWriteMultipleAck, 0x00D2, 2, {}, std::nullopt},  // ack: 2 regs written @0x00D2
    {"§8.67", 2053, Role::kRequestNoReply, "01 06 00 D4 01 00 C8 62", Shape::kWriteSingle, 0x00D4, 1, {0x0100}, std::nullopt},  // write 0x00D4 := 0x0100 (256) (restart; the drive sends no reply)
    {"§8.68", 2070, Role::kEcho, "01 06 00 DB 00 01 38 31", Shape::kWriteSingle, 0x00DB, 1, {0x0001}, std::nullopt},  // write 0x00DB := 0x0001 (1) (start stored program)
    {"§8.69", 2089, Role::kEcho, "01 06 00 DC 00 01 89 F0", Shape::kWriteSingle, 0x00DC, 1, {0x0001}, std::nullopt},  // write 0x00DC := 0x0001 (1) (save to flash)
};
// Frames as PRINTED in the manual whose CRC is wrong: {ref, line, printed, corrected or ""}.
const std::vector<PrintedFrame> kPrintedBadCrc = {
    {"§8.1", 238, "01 03 00 00 00 00 02 C4", "01 03 00 00 00 02 C4 0B"},
    {"§8.1", 240, "01 03 04 37 31 00 30 A5", "01 03 04 37 31 00 30 A5 9C"},
    {"§8.2", 260, "01 03 04 30 31 00 35 64", "01 03 04 30 31 00 35 64 EB"},
    {"§8.3", 278, "01 03 04 00 00 00 00 FA", "01 03 04 00 00 00 00 FA 33"},
    {"§8.4", 317, "01 03 04 18 00 02 00 7D", ""},
    {"§8.11", 483, "01 03 00 0E 00 01 EF C9", "01 03 00 0E 00 01 E5 C9"},
    {"§8.25", 795, "01 03 00 1F 00 01 B5 0C", "01 03 00 1F 00 01 B5 CC"},
    {"§8.46", 1276, "01 10 00 70 00 02 27 10 00 00 FF FA", "01 10 00 70 00 02 04 27 10 00 00 FF FA"},
    {"§8.50", 1423, "01 03 02 01 00 03 F8 45", "01 03 02 00 03 F8 45"},
    {"§8.51", 1491, "01 03 02 00 00 03 B8 44", "01 03 02 00 00 B8 44"},
    {"§8.51", 1507, "01 06 00 A6 01 01 C8 19", "01 06 00 A6 01 01 A9 B9"},
    {"§8.52", 1533, "01 06 00 A4 00 00 04 29", "01 06 00 A4 00 00 C8 29"},
    {"§8.57", 1706, "01 03 00 B6 04 00 C8 15 00 75 5D", "01 03 04 00 C8 15 00 75 5D"},
    {"§8.59", 1759, "01 06 00 BE FF FB E9 D9", "01 06 00 BE FF FB E9 9D"},
};
// clang-format on

std::string name(const ManualFrame& f) { return std::string(f.ref) + " seed line " + std::to_string(f.seed_line); }

rtu::RequestPdu expected_request_pdu(const ManualFrame& f) {
  switch (f.shape) {
    case Shape::kReadRequest: return rtu::ReadRegisters{f.address, f.quantity};
    case Shape::kWriteSingle: return rtu::WriteRegister{f.address, f.values.at(0)};
    default: return rtu::WriteRegisters{f.address, f.values};
  }
}

void check_value32(const ManualFrame& f) {
  if (!f.value32) return;
  ASSERT_EQ(f.values.size(), 2U);
  EXPECT_EQ(decode32_signed(f.values[0], f.values[1]), *f.value32) << name(f);
  EXPECT_EQ(encode32(static_cast<std::int32_t>(*f.value32)), (std::array<std::uint16_t, 2>{f.values[0], f.values[1]}))
      << name(f);
}

void check_as_request(const ManualFrame& f, const std::vector<std::uint8_t>& bytes) {
  const rtu::Request expected{1, expected_request_pdu(f)};
  const auto parsed = rtu::decode_request(bytes);
  ASSERT_TRUE(std::holds_alternative<rtu::Request>(parsed)) << name(f);
  EXPECT_EQ(std::get<rtu::Request>(parsed), expected) << name(f);
  const auto encoded = rtu::encode_request(expected);
  ASSERT_TRUE(encoded.ok()) << name(f);
  EXPECT_EQ(to_hex(encoded.value()), to_hex(bytes)) << name(f);
  EXPECT_FALSE(check_request(expected.pdu).has_value()) << name(f) << ": the map refuses the manual's own request";
  EXPECT_EQ(expects_reply(expected), f.role != Role::kRequestNoReply) << name(f);
  check_value32(f);
}

void check_as_response(const ManualFrame& f, const std::vector<std::uint8_t>& bytes) {
  rtu::Response expected{1, {}};
  rtu::Request request{1, {}};
  switch (f.shape) {
    case Shape::kReadResponse:
      expected.pdu = rtu::ReadRegistersReply{f.values};
      request.pdu = rtu::ReadRegisters{0, f.quantity};
      break;
    case Shape::kWriteSingle:
      expected.pdu = rtu::WriteRegisterReply{f.address, f.values.at(0)};
      request.pdu = expected_request_pdu(f);
      break;
    case Shape::kWriteMultipleAck:
      expected.pdu = rtu::WriteRegistersReply{f.address, f.quantity};
      request.pdu = rtu::WriteRegisters{f.address, std::vector<std::uint16_t>(f.quantity, 0)};
      break;
    default: FAIL() << name(f) << ": not a response shape";
  }
  const auto decoded = rtu::decode_response(bytes);
  ASSERT_TRUE(decoded.ok()) << name(f) << ": " << decoded.error().message();
  EXPECT_EQ(decoded.value(), expected) << name(f);
  const auto paired = rtu::decode_response(bytes, request);
  EXPECT_TRUE(paired.ok()) << name(f) << ": " << paired.error().message();
  EXPECT_EQ(to_hex(rtu::encode_response(expected)), to_hex(bytes)) << name(f);
  if (f.shape != Shape::kReadResponse) {
    EXPECT_EQ(rtu::write_acknowledgement(request), expected) << name(f) << ": slave-built acknowledgement";
  }
  check_value32(f);
}

TEST(AdamManualFrames, EveryExampleFrameDecodesAndReencodesExactly) {
  ASSERT_EQ(kManualFrames.size(), 228U);  // 5.1 rows minus the unrecoverable §8.4 reply
  for (const ManualFrame& f : kManualFrames) {
    const auto bytes = hex(f.hex);
    ASSERT_TRUE(rtu::crc_ok(bytes)) << name(f);
    EXPECT_EQ(bytes[0], 1) << name(f);
    switch (f.role) {
      case Role::kRequest:
      case Role::kRequestNoReply: check_as_request(f, bytes); break;
      case Role::kResponse: check_as_response(f, bytes); break;
      case Role::kEcho:
        check_as_request(f, bytes);
        check_as_response(f, bytes);
        break;
    }
  }
}

TEST(AdamManualFrames, PrintedFramesWithWrongCrcAreRejectedForCrc) {
  ASSERT_EQ(kPrintedBadCrc.size(), 14U);
  for (const PrintedFrame& f : kPrintedBadCrc) {
    const auto printed = hex(f.printed);
    EXPECT_FALSE(rtu::crc_ok(printed)) << f.ref << " " << f.seed_line;
    const auto as_request = rtu::decode_request(printed);
    ASSERT_TRUE(std::holds_alternative<rtu::FrameErrc>(as_request)) << f.ref << " " << f.seed_line;
    EXPECT_EQ(std::get<rtu::FrameErrc>(as_request), rtu::FrameErrc::kBadCrc) << f.ref << " " << f.seed_line;
    EXPECT_EQ(rtu::decode_response(printed).error(), rtu::FrameErrc::kBadCrc) << f.ref << " " << f.seed_line;
    if (!f.corrected.empty()) { EXPECT_TRUE(rtu::crc_ok(hex(f.corrected))) << f.ref << " " << f.seed_line; }
  }
}

TEST(AdamManualFrames, VersionStringsDecodeLittleEndianInLowWordFirstUint32) {
  // §8.1/§8.2 replies (corrected): registers {0x3731, 0x0030} and {0x3031, 0x0035}.
  EXPECT_EQ(decode_version(0x3731, 0x0030), "170");
  EXPECT_EQ(decode_version(0x3031, 0x0035), "105");
}

}  // namespace
}  // namespace motion::adam
