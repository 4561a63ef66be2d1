#include "motion/uim242/feedback.hpp"

#include <algorithm>

#include "motion/uim242/packing.hpp"

namespace motion::uim242 {
namespace {

bool is_header(std::uint8_t b) {
  return b == static_cast<std::uint8_t>(Header::kAck) || b == static_cast<std::uint8_t>(Header::kStatus) ||
         b == static_cast<std::uint8_t>(Header::kError);
}
bool is_terminator(std::uint8_t b) { return b == kLastFrame || b == kMoreFrames; }

// Field widths of each layout, in bytes, in wire order; the sign says how to extend them.
struct Field {
  std::uint8_t bytes;
  bool is_signed;
};
std::vector<Field> fields_of(Layout layout) {
  switch (layout) {
    case Layout::kNone: return {};
    case Layout::kStatus: return {{1, false}, {1, false}, {kPacked16, true}, {kPacked32, true}};
    case Layout::kByte: return {{1, false}};
    case Layout::kU16: return {{kPacked16, false}};
    case Layout::kS16: return {{kPacked16, true}};
    case Layout::kU32: return {{kPacked32, false}};
    case Layout::kS32: return {{kPacked32, true}};
    case Layout::kFlagU32: return {{1, false}, {kPacked32, false}};
    case Layout::kFlagS32: return {{1, false}, {kPacked32, true}};
    case Layout::kScf: return {{kPacked32, false}, {kPacked12, false}, {kPacked12, false}};
    case Layout::kSensors: return {{1, false}, {1, false}, {1, false}, {kPacked12, false}};
    case Layout::kStg: return {{kPacked16, false}, {kPacked16, false}, {kPacked16, false}};
    case Layout::kModel: return {{1, false}, {1, false}, {1, false}, {1, false}, {kPacked16, false}};
    case Layout::kIdList: return std::vector<Field>(8, Field{1, false});
    case Layout::kRaw: return {};
  }
  return {};
}

std::int64_t decode_field(std::span<const std::uint8_t> bytes, Field f) {
  if (f.bytes == 1) return bytes[0];
  if (f.bytes == kPacked16)
    return f.is_signed ? std::int64_t{unpack_s16(bytes)} : std::int64_t{unpack(bytes) & 0xFFFFu};
  if (f.bytes == kPacked32) return f.is_signed ? std::int64_t{unpack_s32(bytes)} : std::int64_t{unpack(bytes)};
  return unpack(bytes) & 0xFFFu;  // 12-bit analog / threshold
}

void append_field(std::vector<std::uint8_t>& out, std::int64_t value, Field f) {
  const auto raw = static_cast<std::uint32_t>(static_cast<std::uint64_t>(value));
  switch (f.bytes) {
    case 1: out.push_back(static_cast<std::uint8_t>(raw & 0x7F)); return;
    case kPacked12: {
      const auto p = packed<kPacked12>(raw);
      out.insert(out.end(), p.begin(), p.end());
      return;
    }
    case kPacked16: {
      const auto p = packed<kPacked16>(raw);
      out.insert(out.end(), p.begin(), p.end());
      return;
    }
    default: {
      const auto p = packed<kPacked32>(raw);
      out.insert(out.end(), p.begin(), p.end());
      return;
    }
  }
}

constexpr std::uint8_t kAsbCurrentReduction = 0x40;
constexpr std::uint8_t kAsbEnabled = 0x20;
constexpr std::uint8_t kAsbPositive = 0x10;
constexpr std::uint8_t kAsbMicroSteps = 0x0F;

ReplyForm ack(std::uint8_t id, Layout layout) { return ReplyForm{Header::kAck, id, layout, false}; }
ReplyForm live(std::uint8_t id, Layout layout) { return ReplyForm{Header::kStatus, id, layout, false}; }
ReplyForm basic_ack() { return ReplyForm{Header::kAck, std::nullopt, Layout::kStatus, false}; }

}  // namespace

Result<Frame> parse_frame(std::span<const std::uint8_t> bytes) {
  if (bytes.empty() || !is_header(bytes.front())) return CodecErrc::kBadHeader;
  if (!is_terminator(bytes.back())) return CodecErrc::kBadTerminator;
  if (bytes.size() > kMaxFrameBytes) return CodecErrc::kFrameTooLong;
  if (bytes.size() < 3) return CodecErrc::kFrameTooShort;
  Frame f;
  f.header = static_cast<Header>(bytes.front());
  f.more_follows = bytes.back() == kMoreFrames;
  const auto body = bytes.subspan(1, bytes.size() - 2);
  if (f.header == Header::kError) {
    // `EE code FF` (the documented form) or `EE id code FF`.
    if (body.size() > 2) return CodecErrc::kWrongLength;
    if (body.size() == 2) f.node = body[0];
    f.data.assign(body.end() - 1, body.end());
    return f;
  }
  if (body[0] >= 0x80) {
    // The gateway greeting AA AB AC ...: no id, message id in the id position (EXT-2501 §2.2).
    f.message_id = body[0];
    f.data.assign(body.begin() + 1, body.end());
    return f;
  }
  f.node = body[0];
  std::size_t data_start = 1;
  if (body.size() > 1 && body[1] >= 0x80) {
    f.message_id = body[1];
    data_start = 2;
  }
  f.data.assign(body.begin() + static_cast<std::ptrdiff_t>(data_start), body.end());
  if (std::any_of(f.data.begin(), f.data.end(), [](std::uint8_t b) { return b >= 0x80; }))
    return CodecErrc::kNotSevenBit;
  return f;
}

std::vector<std::uint8_t> serialize(const Frame& frame) {
  std::vector<std::uint8_t> out{static_cast<std::uint8_t>(frame.header)};
  const bool greeting = frame.header == Header::kAck && frame.message_id && frame.message_id == message::kGreeting;
  const bool bare_error = frame.header == Header::kError && frame.node == 0;
  if (!greeting && !bare_error) out.push_back(frame.node);
  if (frame.message_id) out.push_back(*frame.message_id);
  out.insert(out.end(), frame.data.begin(), frame.data.end());
  out.push_back(frame.more_follows ? kMoreFrames : kLastFrame);
  return out;
}

std::size_t data_length(Layout layout) noexcept {
  std::size_t n = 0;
  for (const auto& f : fields_of(layout)) n += f.bytes;
  return n;
}

Result<std::vector<std::int64_t>> decode_fields(std::span<const std::uint8_t> data, Layout layout) {
  std::vector<std::int64_t> out;
  if (layout == Layout::kRaw) {
    out.assign(data.begin(), data.end());
    return out;
  }
  if (data.size() != data_length(layout)) return CodecErrc::kWrongLength;
  std::size_t offset = 0;
  for (const auto& f : fields_of(layout)) {
    out.push_back(decode_field(data.subspan(offset, f.bytes), f));
    offset += f.bytes;
  }
  return out;
}

std::vector<std::uint8_t> encode_fields(Layout layout, std::span<const std::int64_t> values) {
  std::vector<std::uint8_t> out;
  if (layout == Layout::kRaw) {
    for (const auto v : values) out.push_back(static_cast<std::uint8_t>(v));
    return out;
  }
  const auto fields = fields_of(layout);
  for (std::size_t i = 0; i < fields.size(); ++i) append_field(out, i < values.size() ? values[i] : 0, fields[i]);
  return out;
}

Result<Status> decode_status(const Frame& frame) {
  if (frame.header == Header::kError || frame.message_id) return CodecErrc::kUnexpectedFrame;
  auto fields = decode_fields(frame.data, Layout::kStatus);
  if (!fields) return fields.error();
  const auto& v = *fields;
  const auto asb = static_cast<std::uint8_t>(v[0]);
  Status s;
  s.current_reduction = (asb & kAsbCurrentReduction) != 0;
  s.enabled = (asb & kAsbEnabled) != 0;
  s.positive_direction = (asb & kAsbPositive) != 0;
  s.micro_steps = static_cast<std::uint8_t>((asb & kAsbMicroSteps) + 1);
  s.current_tenths = static_cast<std::uint8_t>(v[1]);
  s.speed = static_cast<std::int16_t>(v[2]);
  s.displacement = static_cast<std::int32_t>(v[3]);
  return s;
}

Frame make_status_frame(Header header, std::uint8_t node, const Status& s) {
  const auto asb =
      static_cast<std::uint8_t>((s.current_reduction ? kAsbCurrentReduction : 0) | (s.enabled ? kAsbEnabled : 0) |
                                (s.positive_direction ? kAsbPositive : 0) | ((s.micro_steps - 1) & kAsbMicroSteps));
  const std::int64_t fields[] = {asb, s.current_tenths, s.speed, s.displacement};
  return Frame{header, node, std::nullopt, encode_fields(Layout::kStatus, fields), false};
}

ReplyForm reply_form(const Instruction& in, OrgReplyStyle org) noexcept {
  namespace m = message;
  if (in.global) {
    if (in.mnemonic == Mnemonic::kREG) return ReplyForm{Header::kStatus, m::kRegister, Layout::kIdList, true};
    // Both Summaries print the gORG ACK with header CC; EXT-2501: every other global ACK is AA.
    const Header h = in.mnemonic == Mnemonic::kORG ? Header::kStatus : Header::kAck;
    return ReplyForm{h, m::kGlobalAck, Layout::kNone, true};
  }
  const bool set = in.value.has_value();
  switch (in.mnemonic) {
    case Mnemonic::kNull:
    case Mnemonic::kCUR:
    case Mnemonic::kOFF:
    case Mnemonic::kMCS: return basic_ack();
    case Mnemonic::kENA: return set ? ack(m::kEnableTimer, Layout::kU16) : basic_ack();
    case Mnemonic::kACR: return set && *in.value <= 1 ? basic_ack() : ack(m::kAcrRatio, Layout::kByte);
    case Mnemonic::kFBK: return ReplyForm{Header::kStatus, std::nullopt, Layout::kStatus, false};
    case Mnemonic::kBLC: return ack(m::kBlc, Layout::kU16);
    case Mnemonic::kDOU: return ack(m::kDou, Layout::kByte);
    case Mnemonic::kICF: return ack(m::kIcf, Layout::kU16);
    case Mnemonic::kMAC: return ack(m::kMac, Layout::kFlagU32);
    case Mnemonic::kMCF: return ack(m::kMcf, Layout::kU16);
    case Mnemonic::kMDE: return ack(m::kMde, Layout::kFlagU32);
    case Mnemonic::kMDL: return live(m::kModel, Layout::kModel);
    case Mnemonic::kMMD: return ack(m::kMmd, Layout::kU16);
    case Mnemonic::kMMS: return ack(m::kMms, Layout::kU16);
    case Mnemonic::kORG:
      return org == OrgReplyStyle::kCn ? live(m::kOrgCn, Layout::kS32) : ack(m::kOrgEn, Layout::kS32);
    case Mnemonic::kQEC: return set ? ack(m::kQecOrSqt, Layout::kS32) : live(m::kEncoderPosition, Layout::kS32);
    case Mnemonic::kQER: return ack(m::kQer, Layout::kU16);
    case Mnemonic::kSCF: return ack(m::kScf, Layout::kScf);
    case Mnemonic::kSFB: return live(m::kSensors, Layout::kSensors);
    case Mnemonic::kSPD: return set ? ack(m::kSpeed, Layout::kS16) : live(m::kCurrentSpeed, Layout::kS16);
    case Mnemonic::kSQT: return ack(m::kQecOrSqt, Layout::kU32);
    case Mnemonic::kSTG: return ack(m::kStg, Layout::kStg);
    case Mnemonic::kSTO: return ack(m::kSto, Layout::kNone);
    case Mnemonic::kSTP: return set ? ack(m::kDisplacement, Layout::kS32) : live(m::kCurrentDisplacement, Layout::kS32);
    case Mnemonic::kADR: return ack(m::kSelect, Layout::kNone);
    case Mnemonic::kSET: return ack(m::kSetId, Layout::kNone);
    case Mnemonic::kBTR: return ack(m::kBitRate, Layout::kNone);
    case Mnemonic::kBDR: return ack(m::kBaud, Layout::kNone);
    case Mnemonic::kABC: return ReplyForm{Header::kAck, m::kGreeting, Layout::kRaw, false};
    case Mnemonic::kREG: break;
  }
  return ReplyForm{Header::kAck, std::nullopt, Layout::kNone, false};
}

bool reply_matches(const Frame& frame, const Instruction& sent) noexcept {
  const auto matches = [&](const ReplyForm& form) {
    if (frame.header != form.header || frame.message_id != form.message_id) return false;
    return form.layout == Layout::kRaw || frame.data.size() == data_length(form.layout);
  };
  if (matches(reply_form(sent, OrgReplyStyle::kCn))) return true;
  return sent.mnemonic == Mnemonic::kORG && !sent.global && matches(reply_form(sent, OrgReplyStyle::kEn));
}

Frame make_reply(const ReplyForm& form, std::uint8_t node, std::span<const std::int64_t> fields) {
  return Frame{form.header, node, form.message_id, encode_fields(form.layout, fields), false};
}

std::optional<ErrorReply> as_error(const Frame& frame) noexcept {
  if (frame.header != Header::kError || frame.data.size() != 1) return std::nullopt;
  const std::uint8_t code = frame.data.front();
  ErrorReply e;
  e.code = std::error_code{code, error_category()};
  if (frame.node != 0) e.node = frame.node;
  return e;
}

Frame make_error(ErrorCode code) {
  return Frame{Header::kError, 0, std::nullopt, {static_cast<std::uint8_t>(code)}, false};
}

std::optional<Notification> as_notification(const Frame& frame, std::uint8_t stall_message_id) noexcept {
  if (frame.header != Header::kStatus || !frame.message_id) return std::nullopt;
  const std::uint8_t id = *frame.message_id;
  Notification n;
  n.node = frame.node;
  if (id == stall_message_id && frame.data.empty()) {
    n.event = Event::kStall;
    return n;
  }
  if (id < 0xA0 || id > 0xA9) return std::nullopt;
  n.event = static_cast<Event>(id);
  if (frame.data.empty()) return n;
  if (n.event != Event::kDisplacementComplete || frame.data.size() != data_length(Layout::kFlagS32))
    return std::nullopt;
  const auto fields = decode_fields(frame.data, Layout::kFlagS32);
  n.closed_loop = (*fields)[0] != 0;
  n.position = static_cast<std::int32_t>((*fields)[1]);
  return n;
}

Frame make_notification(const Notification& n, std::uint8_t stall_message_id) {
  Frame f{Header::kStatus, n.node, static_cast<std::uint8_t>(n.event), {}, false};
  if (n.event == Event::kStall) f.message_id = stall_message_id;
  if (n.event == Event::kDisplacementComplete && n.position) {
    const std::int64_t fields[] = {n.closed_loop.value_or(false) ? 1 : 0, *n.position};
    f.data = encode_fields(Layout::kFlagS32, fields);
  }
  return f;
}

std::optional<Greeting> as_greeting(const Frame& frame) noexcept {
  // AA AB AC 19 01 00 00 00 00 00 [ver1] [ver0] FF (EXT-2501 §2.2).
  if (frame.header != Header::kAck || frame.message_id != message::kGreeting || frame.data.size() != 10 ||
      frame.data[0] != 0xAC) {
    return std::nullopt;
  }
  return Greeting{frame.data[8], frame.data[9]};
}

Frame make_greeting(Greeting g) {
  return Frame{
      Header::kAck, 0, message::kGreeting, {0xAC, 0x19, 0x01, 0, 0, 0, 0, 0, g.version_high, g.version_low}, false};
}

// ---- FeedbackFramer ---------------------------------------------------------------------------

std::vector<std::vector<std::uint8_t>> FeedbackFramer::push(std::span<const std::uint8_t> bytes) {
  std::vector<std::vector<std::uint8_t>> out;
  for (const std::uint8_t b : bytes) {
    if (current_.empty()) {
      if (is_header(b)) {
        current_.push_back(b);
      } else {
        ++noise_;
      }
      continue;
    }
    // Past the message-id position every byte of an AA/CC frame is 7-bit data or the
    // terminator: a header byte there means the terminator was lost; start over at it.
    const bool greeting = current_.size() > 1 && current_[1] >= 0x80;
    if (is_header(b) && current_.size() >= 3 && !greeting) {
      noise_ += current_.size();
      current_.assign(1, b);
      continue;
    }
    current_.push_back(b);
    if (is_terminator(b)) {
      out.push_back(std::move(current_));
      current_.clear();
    } else if (current_.size() >= kMaxFrameBytes) {
      // Oversize: drop the header and rescan what followed it for the next header.
      ++oversize_;
      const auto next = std::find_if(current_.begin() + 1, current_.end(), is_header);
      noise_ += static_cast<std::uint64_t>(next - current_.begin());
      current_.erase(current_.begin(), next);
    }
  }
  return out;
}

}  // namespace motion::uim242
