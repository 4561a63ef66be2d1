#include "motion/uim242/feedback.hpp"

#include <algorithm>

#include "motion/uim242/packing.hpp"

namespace motion::uim242 {
namespace {

bool is_header(std::uint8_t b) {
  return b == static_cast<std::uint8_t>(Header::ack) || b == static_cast<std::uint8_t>(Header::status) ||
         b == static_cast<std::uint8_t>(Header::error);
}
bool is_terminator(std::uint8_t b) { return b == kLastFrame || b == kMoreFrames; }

// Field widths of each layout, in bytes, in wire order; the sign says how to extend them.
struct Field {
  std::uint8_t bytes;
  bool is_signed;
};
std::vector<Field> fields_of(Layout layout) {
  switch (layout) {
    case Layout::none: return {};
    case Layout::status: return {{1, false}, {1, false}, {kPacked16, true}, {kPacked32, true}};
    case Layout::byte: return {{1, false}};
    case Layout::u16: return {{kPacked16, false}};
    case Layout::s16: return {{kPacked16, true}};
    case Layout::u32: return {{kPacked32, false}};
    case Layout::s32: return {{kPacked32, true}};
    case Layout::flag_u32: return {{1, false}, {kPacked32, false}};
    case Layout::flag_s32: return {{1, false}, {kPacked32, true}};
    case Layout::scf: return {{kPacked32, false}, {kPacked12, false}, {kPacked12, false}};
    case Layout::sensors: return {{1, false}, {1, false}, {1, false}, {kPacked12, false}};
    case Layout::stg: return {{kPacked16, false}, {kPacked16, false}, {kPacked16, false}};
    case Layout::model: return {{1, false}, {1, false}, {1, false}, {1, false}, {kPacked16, false}};
    case Layout::id_list: return std::vector<Field>(8, Field{1, false});
    case Layout::raw: return {};
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

ReplyForm ack(std::uint8_t id, Layout layout) { return ReplyForm{Header::ack, id, layout, false}; }
ReplyForm live(std::uint8_t id, Layout layout) { return ReplyForm{Header::status, id, layout, false}; }
ReplyForm basic_ack() { return ReplyForm{Header::ack, std::nullopt, Layout::status, false}; }

}  // namespace

Result<Frame> parse_frame(std::span<const std::uint8_t> bytes) {
  if (bytes.empty() || !is_header(bytes.front())) return CodecErrc::bad_header;
  if (!is_terminator(bytes.back())) return CodecErrc::bad_terminator;
  if (bytes.size() > kMaxFrameBytes) return CodecErrc::frame_too_long;
  if (bytes.size() < 3) return CodecErrc::frame_too_short;
  Frame f;
  f.header = static_cast<Header>(bytes.front());
  f.more_follows = bytes.back() == kMoreFrames;
  const auto body = bytes.subspan(1, bytes.size() - 2);
  if (f.header == Header::error) {
    // `EE code FF` (the documented form) or `EE id code FF`.
    if (body.size() > 2) return CodecErrc::wrong_length;
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
    return CodecErrc::not_seven_bit;
  return f;
}

std::vector<std::uint8_t> serialize(const Frame& frame) {
  std::vector<std::uint8_t> out{static_cast<std::uint8_t>(frame.header)};
  const bool greeting = frame.header == Header::ack && frame.message_id && frame.message_id == message::kGreeting;
  const bool bare_error = frame.header == Header::error && frame.node == 0;
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
  if (layout == Layout::raw) {
    out.assign(data.begin(), data.end());
    return out;
  }
  if (data.size() != data_length(layout)) return CodecErrc::wrong_length;
  std::size_t offset = 0;
  for (const auto& f : fields_of(layout)) {
    out.push_back(decode_field(data.subspan(offset, f.bytes), f));
    offset += f.bytes;
  }
  return out;
}

std::vector<std::uint8_t> encode_fields(Layout layout, std::span<const std::int64_t> values) {
  std::vector<std::uint8_t> out;
  if (layout == Layout::raw) {
    for (const auto v : values) out.push_back(static_cast<std::uint8_t>(v));
    return out;
  }
  const auto fields = fields_of(layout);
  for (std::size_t i = 0; i < fields.size(); ++i) append_field(out, i < values.size() ? values[i] : 0, fields[i]);
  return out;
}

Result<Status> decode_status(const Frame& frame) {
  if (frame.header == Header::error || frame.message_id) return CodecErrc::unexpected_frame;
  auto fields = decode_fields(frame.data, Layout::status);
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
  return Frame{header, node, std::nullopt, encode_fields(Layout::status, fields), false};
}

ReplyForm reply_form(const Instruction& in, OrgReplyStyle org) noexcept {
  namespace m = message;
  if (in.global) {
    if (in.mnemonic == Mnemonic::REG) return ReplyForm{Header::status, m::kRegister, Layout::id_list, true};
    // Both Summaries print the gORG ACK with header CC; EXT-2501: every other global ACK is AA.
    const Header h = in.mnemonic == Mnemonic::ORG ? Header::status : Header::ack;
    return ReplyForm{h, m::kGlobalAck, Layout::none, true};
  }
  const bool set = in.value.has_value();
  switch (in.mnemonic) {
    case Mnemonic::Null:
    case Mnemonic::CUR:
    case Mnemonic::OFF:
    case Mnemonic::MCS: return basic_ack();
    case Mnemonic::ENA: return set ? ack(m::kEnableTimer, Layout::u16) : basic_ack();
    case Mnemonic::ACR: return set && *in.value <= 1 ? basic_ack() : ack(m::kAcrRatio, Layout::byte);
    case Mnemonic::FBK: return ReplyForm{Header::status, std::nullopt, Layout::status, false};
    case Mnemonic::BLC: return ack(m::kBlc, Layout::u16);
    case Mnemonic::DOU: return ack(m::kDou, Layout::byte);
    case Mnemonic::ICF: return ack(m::kIcf, Layout::u16);
    case Mnemonic::MAC: return ack(m::kMac, Layout::flag_u32);
    case Mnemonic::MCF: return ack(m::kMcf, Layout::u16);
    case Mnemonic::MDE: return ack(m::kMde, Layout::flag_u32);
    case Mnemonic::MDL: return live(m::kModel, Layout::model);
    case Mnemonic::MMD: return ack(m::kMmd, Layout::u16);
    case Mnemonic::MMS: return ack(m::kMms, Layout::u16);
    case Mnemonic::ORG: return org == OrgReplyStyle::cn ? live(m::kOrgCn, Layout::s32) : ack(m::kOrgEn, Layout::s32);
    case Mnemonic::QEC: return set ? ack(m::kQecOrSqt, Layout::s32) : live(m::kEncoderPosition, Layout::s32);
    case Mnemonic::QER: return ack(m::kQer, Layout::u16);
    case Mnemonic::SCF: return ack(m::kScf, Layout::scf);
    case Mnemonic::SFB: return live(m::kSensors, Layout::sensors);
    case Mnemonic::SPD: return set ? ack(m::kSpeed, Layout::s16) : live(m::kCurrentSpeed, Layout::s16);
    case Mnemonic::SQT: return ack(m::kQecOrSqt, Layout::u32);
    case Mnemonic::STG: return ack(m::kStg, Layout::stg);
    case Mnemonic::STO: return ack(m::kSto, Layout::none);
    case Mnemonic::STP: return set ? ack(m::kDisplacement, Layout::s32) : live(m::kCurrentDisplacement, Layout::s32);
    case Mnemonic::ADR: return ack(m::kSelect, Layout::none);
    case Mnemonic::SET: return ack(m::kSetId, Layout::none);
    case Mnemonic::BTR: return ack(m::kBitRate, Layout::none);
    case Mnemonic::BDR: return ack(m::kBaud, Layout::none);
    case Mnemonic::ABC: return ReplyForm{Header::ack, m::kGreeting, Layout::raw, false};
    case Mnemonic::REG: break;
  }
  return ReplyForm{Header::ack, std::nullopt, Layout::none, false};
}

bool reply_matches(const Frame& frame, const Instruction& sent) noexcept {
  const auto matches = [&](const ReplyForm& form) {
    if (frame.header != form.header || frame.message_id != form.message_id) return false;
    return form.layout == Layout::raw || frame.data.size() == data_length(form.layout);
  };
  if (matches(reply_form(sent, OrgReplyStyle::cn))) return true;
  return sent.mnemonic == Mnemonic::ORG && !sent.global && matches(reply_form(sent, OrgReplyStyle::en));
}

Frame make_reply(const ReplyForm& form, std::uint8_t node, std::span<const std::int64_t> fields) {
  return Frame{form.header, node, form.message_id, encode_fields(form.layout, fields), false};
}

std::optional<ErrorReply> as_error(const Frame& frame) noexcept {
  if (frame.header != Header::error || frame.data.size() != 1) return std::nullopt;
  const std::uint8_t code = frame.data.front();
  ErrorReply e;
  e.code = std::error_code{code, error_category()};
  if (frame.node != 0) e.node = frame.node;
  return e;
}

Frame make_error(ErrorCode code) {
  return Frame{Header::error, 0, std::nullopt, {static_cast<std::uint8_t>(code)}, false};
}

std::optional<Notification> as_notification(const Frame& frame, std::uint8_t stall_message_id) noexcept {
  if (frame.header != Header::status || !frame.message_id) return std::nullopt;
  const std::uint8_t id = *frame.message_id;
  Notification n;
  n.node = frame.node;
  if (id == stall_message_id && frame.data.empty()) {
    n.event = Event::stall;
    return n;
  }
  if (id < 0xA0 || id > 0xA9) return std::nullopt;
  n.event = static_cast<Event>(id);
  if (frame.data.empty()) return n;
  if (n.event != Event::displacement_complete || frame.data.size() != data_length(Layout::flag_s32))
    return std::nullopt;
  const auto fields = decode_fields(frame.data, Layout::flag_s32);
  n.closed_loop = (*fields)[0] != 0;
  n.position = static_cast<std::int32_t>((*fields)[1]);
  return n;
}

Frame make_notification(const Notification& n, std::uint8_t stall_message_id) {
  Frame f{Header::status, n.node, static_cast<std::uint8_t>(n.event), {}, false};
  if (n.event == Event::stall) f.message_id = stall_message_id;
  if (n.event == Event::displacement_complete && n.position) {
    const std::int64_t fields[] = {n.closed_loop.value_or(false) ? 1 : 0, *n.position};
    f.data = encode_fields(Layout::flag_s32, fields);
  }
  return f;
}

std::optional<Greeting> as_greeting(const Frame& frame) noexcept {
  // AA AB AC 19 01 00 00 00 00 00 [ver1] [ver0] FF (EXT-2501 §2.2).
  if (frame.header != Header::ack || frame.message_id != message::kGreeting || frame.data.size() != 10 ||
      frame.data[0] != 0xAC) {
    return std::nullopt;
  }
  return Greeting{frame.data[8], frame.data[9]};
}

Frame make_greeting(Greeting g) {
  return Frame{
      Header::ack, 0, message::kGreeting, {0xAC, 0x19, 0x01, 0, 0, 0, 0, 0, g.version_high, g.version_low}, false};
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
