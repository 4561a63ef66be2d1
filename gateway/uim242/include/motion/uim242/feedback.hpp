// UIM242 feedback (controller/gateway -> host): frame layout, the reply catalogue per
// instruction, status, notifications, errors, and incremental framing of the byte stream.
// EN/CN §2.2, §4, §6.2-§6.3, §12.2-§12.3.
//
// Frame: `[AA|CC|EE] [ID] [message id] [7-bit data...] [FF|FE]`, at most 13 bytes documented.
// * AA = ACK of an instruction, CC = status (FBK, live values, RTCN), EE = error.
// * The basic ACK (AA) and the FBK status (CC) have no message id: ID is followed directly by
//   10 data bytes (a data byte < 0x80 where the message id would be; our reading of §12.2).
// * Error frames are `EE code FF` (EN/CN §6.2); `EE id code FF` is accepted too (not in the manuals).
// * The gateway greeting `AA AB AC ...` has a byte >= 0x80 in the id position (EXT-2501 §2.2).
//
// Decisions where the manuals are silent or disagree:
// * ORG reply (EN and CN #28/#29 differ): the simulator uses CN `CC id B0 s32` by default;
//   reply_matches() accepts EN `AA id B7 s32` too.
// * `AA B8` is both the QEC η and the SQT reply (EN/CN #30, #39/#40): matching is by what was sent.
// * A8 completion RTCN (EN §4.1 vs CN §4.1): the 10-byte CN form (closed-loop flag + s32 position)
//   by default, the 4-byte EN form accepted.
// * Stall notification (MCFG.STLIE, EN/CN §5.4): message id undocumented; `CC id AA FF` by default,
//   the id is a parameter.
// * FE terminator (EN/CN §2.2, §12.2; tied to no instruction): framed exactly like FF, with
//   more_follows set.
// Thread contract: pure functions; FeedbackFramer is a single-threaded value type.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <vector>

#include "motion/uim242/errors.hpp"
#include "motion/uim242/instruction.hpp"

namespace motion::uim242 {

enum class Header : std::uint8_t { kAck = 0xAA, kStatus = 0xCC, kError = 0xEE };
inline constexpr std::uint8_t kLastFrame = 0xFF;   // terminator: nothing follows
inline constexpr std::uint8_t kMoreFrames = 0xFE;  // terminator: more frames follow

// Message ids of the Instruction Set Summary and EN/CN §4.1, §12.3. Replies and RTCNs share numbers
// across headers.
namespace message {
inline constexpr std::uint8_t kEnableTimer = 0xA0;  // AA: ENA η
inline constexpr std::uint8_t kGlobalAck = 0xAD;    // AA/CC: global g... (QTY in the id byte)
inline constexpr std::uint8_t kMcf = 0xB0;          // AA: MCF; CC: ORG (CN)
inline constexpr std::uint8_t kOrgCn = 0xB0;
inline constexpr std::uint8_t kMac = 0xB1;  // AA: MAC; CC: QEC;
inline constexpr std::uint8_t kEncoderPosition = 0xB1;
inline constexpr std::uint8_t kMde = 0xB2;  // AA: MDE; CC: SPD;
inline constexpr std::uint8_t kCurrentSpeed = 0xB2;
inline constexpr std::uint8_t kMms = 0xB3;  // AA: MMS; CC: STP;
inline constexpr std::uint8_t kCurrentDisplacement = 0xB3;
inline constexpr std::uint8_t kMmd = 0xB4;
inline constexpr std::uint8_t kSpeed = 0xB5;
inline constexpr std::uint8_t kDisplacement = 0xB6;
inline constexpr std::uint8_t kOrgEn = 0xB7;
inline constexpr std::uint8_t kQecOrSqt = 0xB8;
inline constexpr std::uint8_t kAcrRatio = 0xBA;
inline constexpr std::uint8_t kBitRate = 0xBC;
inline constexpr std::uint8_t kBaud = 0xBD;
inline constexpr std::uint8_t kScf = 0xC0;
inline constexpr std::uint8_t kDou = 0xC1;  // AA: DOU; CC: SFB
inline constexpr std::uint8_t kSensors = 0xC1;
inline constexpr std::uint8_t kQer = 0xC2;
inline constexpr std::uint8_t kStg = 0xC9;
inline constexpr std::uint8_t kSelect = 0xD0;  // AA: ADR; CC: gREG
inline constexpr std::uint8_t kRegister = 0xD0;
inline constexpr std::uint8_t kSto = 0xD1;
inline constexpr std::uint8_t kIcf = 0xDA;
inline constexpr std::uint8_t kSetId = 0xDD;
inline constexpr std::uint8_t kBlc = 0xDE;  // AA: BLC; CC: MDL
inline constexpr std::uint8_t kModel = 0xDE;
inline constexpr std::uint8_t kGreeting = 0xAB;      // AA AB AC ... (EXT-2501)
inline constexpr std::uint8_t kDefaultStall = 0xAA;  // not in the manuals (stall id undocumented): our choice
}  // namespace message

// A frame as split from the stream.
struct Frame {
  Header header = Header::kAck;
  std::uint8_t node = 0;                   // controller id; QTY for global ACK / gREG; 0 for `EE code FF`
  std::optional<std::uint8_t> message_id;  // none: basic ACK, FBK status, error
  std::vector<std::uint8_t> data;          // between message id (or id) and terminator
  bool more_follows = false;               // FE terminator
  friend bool operator==(const Frame&, const Frame&) = default;
};

inline constexpr std::size_t kMaxFrameBytes =
    16;  // not in the manuals (13 bytes at most documented, §12.2): cap, then resync

// One complete frame (header .. terminator).
[[nodiscard]] Result<Frame> parse_frame(std::span<const std::uint8_t> bytes);
[[nodiscard]] std::vector<std::uint8_t> serialize(const Frame& frame);

// ---- Data layouts ------------------------------------------------------------------------------

enum class Layout : std::uint8_t {
  kNone,    // STO, ADR, SET, global ACKs, plain RTCN
  kStatus,  // ASB CUR s16 s32 (basic ACK, FBK)
  kByte,    // b (ACR ratio, DOU level)
  kU16,
  kS16,
  kU32,
  kS32,
  kFlagU32,  // b + u32 (MAC/MDE: b = AM/DM)
  kFlagS32,  // b + s32 (CN A8 RTCN: closed-loop flag + position)
  kScf,      // u32 (S34CON:S12CON) u12 (ATCONL) u12 (ATCONH)
  kSensors,  // b b b u12 (S1 S2 S3 logic, analog)
  kStg,      // u16 u16 u16 (S1 S2 S3 intervals)
  kModel,    // 18 02 b (max current x10) b (modules) u16 (firmware)
  kIdList,   // 8 raw ids (gREG)
  kRaw,      // greeting: bytes as they are
};
[[nodiscard]] std::size_t data_length(Layout layout) noexcept;  // 0 for raw

// Decodes the data into its fields in order (e.g. scf: {u32, atconl, atconh}; status: {asb, cur,
// speed, displacement}; model: {0x18, 0x02, cur, modules, firmware}); signed fields sign-extended.
[[nodiscard]] Result<std::vector<std::int64_t>> decode_fields(std::span<const std::uint8_t> data, Layout layout);
// The inverse; fields are truncated to their wire width (e.g. SPD 40000 echoes as -25536, EN/CN #37).
[[nodiscard]] std::vector<std::uint8_t> encode_fields(Layout layout, std::span<const std::int64_t> fields);

// ---- Status (basic ACK and FBK) ---------------------------------------------------------------

// ASB bits (EN §6.2): 6 ACR on, 5 enabled, 4 direction positive, 3..0 micro-steps - 1.
struct Status {
  bool current_reduction = false;
  bool enabled = false;
  bool positive_direction = true;
  std::uint8_t micro_steps = 16;
  std::uint8_t current_tenths = 0;  // CUR, 0.1 A
  std::int16_t speed = 0;           // desired (ACK) or actual (FBK), pps
  std::int32_t displacement = 0;    // desired STP (ACK) or displacement counter (FBK)
  friend bool operator==(const Status&, const Status&) = default;
};
[[nodiscard]] Result<Status> decode_status(const Frame& frame);
// header ack = basic ACK (desired values), status = FBK reply (current values).
[[nodiscard]] Frame make_status_frame(Header header, std::uint8_t node, const Status& status);

// ---- Replies ------------------------------------------------------------------------------------

enum class OrgReplyStyle : std::uint8_t { kCn, kEn };  // EN and CN #28/#29 differ

// What a controller/gateway answers to an instruction (EN/CN §12.3, the Summary; EXT-2501 §2-§3).
struct ReplyForm {
  Header header = Header::kAck;
  std::optional<std::uint8_t> message_id;  // none: basic status
  Layout layout = Layout::kNone;
  bool node_is_quantity = false;  // global ACK / gREG: the id byte is a count
};
[[nodiscard]] ReplyForm reply_form(const Instruction& instruction, OrgReplyStyle org = OrgReplyStyle::kCn) noexcept;
// True when `frame` is the reply to `sent` (either ORG style).
[[nodiscard]] bool reply_matches(const Frame& frame, const Instruction& sent) noexcept;
// The frame a controller (or the gateway) sends in reply; fields as for encode_fields.
[[nodiscard]] Frame make_reply(const ReplyForm& form, std::uint8_t node, std::span<const std::int64_t> fields);

// Error frames. nullopt when the frame is not an error frame.
struct ErrorReply {
  std::error_code code;  // category "uim242" (unknown codes keep their number)
  std::optional<std::uint8_t> node;
};
[[nodiscard]] std::optional<ErrorReply> as_error(const Frame& frame) noexcept;
[[nodiscard]] Frame make_error(ErrorCode code);

// ---- Real-time change notifications (EN/CN §4.0-§4.2, Table 4-1) -------------------------------

enum class Event : std::uint8_t {
  kS1Falling = 0xA0,
  kS1Rising = 0xA1,
  kS2Falling = 0xA2,
  kS2Rising = 0xA3,
  kS3Falling = 0xA4,
  kS3Rising = 0xA5,
  kP4HighToLow = 0xA6,
  kP4LowToHigh = 0xA7,
  kDisplacementComplete = 0xA8,
  kPositionZero = 0xA9,
  kStall = 0x00,  // its message id is a parameter (undocumented in EN/CN §5.4)
};
struct Notification {
  std::uint8_t node = 0;
  Event event = Event::kS1Falling;
  std::optional<bool> closed_loop;  // CN A8 only
  std::optional<std::int32_t> position;
  friend bool operator==(const Notification&, const Notification&) = default;
};
[[nodiscard]] std::optional<Notification> as_notification(
    const Frame& frame, std::uint8_t stall_message_id = message::kDefaultStall) noexcept;
[[nodiscard]] Frame make_notification(const Notification& n, std::uint8_t stall_message_id = message::kDefaultStall);

// ---- Gateway frames (EXT-2501) ------------------------------------------------------------------

struct Greeting {
  std::uint8_t version_high = 0;
  std::uint8_t version_low = 0;
};
[[nodiscard]] std::optional<Greeting> as_greeting(const Frame& frame) noexcept;
[[nodiscard]] Frame make_greeting(Greeting greeting);

// ---- Incremental framing ------------------------------------------------------------------------

// Splits the gateway's byte stream into frames. Bytes arrive in arbitrary pieces. A frame starts
// with AA/CC/EE and ends at the first FF/FE; bytes before a header are noise and skipped; a frame
// that reaches kMaxFrameBytes without a terminator is dropped and the scan resumes at the next
// byte (not stated in the manuals; our reading of §12.2). Only complete byte runs come out; parse
// them with parse_frame().
class FeedbackFramer {
 public:
  std::vector<std::vector<std::uint8_t>> push(std::span<const std::uint8_t> bytes);
  [[nodiscard]] std::uint64_t noise_bytes() const noexcept { return noise_; }
  [[nodiscard]] std::uint64_t oversize_frames() const noexcept { return oversize_; }
  [[nodiscard]] bool mid_frame() const noexcept { return !current_.empty(); }
  void reset() noexcept { current_.clear(); }

 private:
  std::vector<std::uint8_t> current_;
  std::uint64_t noise_ = 0;
  std::uint64_t oversize_ = 0;
};

}  // namespace motion::uim242
