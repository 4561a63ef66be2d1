#include "motion/uim342/instructions.hpp"

#include <algorithm>
#include <array>
#include <iterator>

#include <fmt/format.h>

#include "motion/core/bytes.hpp"

namespace motion::uim342 {
namespace {

using FC = FunctionCode;
using L = Layout;

// Instruction forms and frame lengths of manual §5.1-§5.29 (and the Instruction Set Summary), one
// row per instruction.
constexpr std::array kTable{
    //               fn     mn    get         set               reply            ack forms             set ACK  i  short
    InstructionForms{FC::kPP, "PP", L::kIndex, L::kIndexedByte, L::kIndexedByte, AckForms::kBoth, FC::kPP, 0, false},
    InstructionForms{FC::kIC, "IC", L::kIndex, L::kIndexedWord, L::kIndexedWord, AckForms::kBoth, FC::kIC, 0, false},
    InstructionForms{FC::kIE, "IE", L::kIndex, L::kIndexedWord, L::kIndexedWord, AckForms::kBoth, FC::kIE, 0, false},
    InstructionForms{FC::kML, "ML", L::kEmpty, L::kNone, L::kModel, AckForms::kAckOnly, FC::kML, 0, false},
    InstructionForms{FC::kSN, "SN", L::kEmpty, L::kNone, L::kSerial, AckForms::kBoth, FC::kSN, 0, false},
    InstructionForms{FC::kER, "ER", L::kIndex, L::kIndexedByte, L::kErrorRecord, AckForms::kBoth, FC::kER, 0, false},
    InstructionForms{FC::kMT, "MT", L::kIndex, L::kIndexedWord, L::kIndexedWord, AckForms::kBoth, FC::kMT, 0, false},
    InstructionForms{FC::kMS, "MS", L::kIndex, L::kIndexedByte, L::kMotionStatus, AckForms::kBoth, FC::kMS, 0, false},
    InstructionForms{FC::kMO, "MO", L::kEmpty, L::kByte, L::kByte, AckForms::kBoth, FC::kMO, 0, false},
    InstructionForms{FC::kBG, "BG", L::kNone, L::kEmpty, L::kZeros4, AckForms::kBoth, FC::kBG, 0, false},
    InstructionForms{FC::kST, "ST", L::kNone, L::kEmpty, L::kEmpty, AckForms::kBoth, FC::kST, 0, false},
    InstructionForms{FC::kMF, "MF", L::kEmpty, L::kByte, L::kByte, AckForms::kBoth, FC::kMF, 0, false},
    InstructionForms{FC::kAC, "AC", L::kEmpty, L::kU32, L::kU32, AckForms::kBoth, FC::kAC, 0, false},
    InstructionForms{FC::kDC, "DC", L::kEmpty, L::kU32, L::kU32, AckForms::kBoth, FC::kDC, 0, false},
    InstructionForms{FC::kSS, "SS", L::kEmpty, L::kU32, L::kU32, AckForms::kBoth, FC::kSS, 0, false},
    InstructionForms{FC::kSD, "SD", L::kEmpty, L::kU32, L::kU32, AckForms::kBoth, FC::kSD, 0, false},
    InstructionForms{FC::kJV, "JV", L::kEmpty, L::kS32, L::kS32, AckForms::kBoth, FC::kDV, 2, true},
    InstructionForms{FC::kSP, "SP", L::kEmpty, L::kS32, L::kS32, AckForms::kBoth, FC::kDV, 2, true},
    InstructionForms{FC::kPR, "PR", L::kEmpty, L::kS32, L::kS32, AckForms::kBoth, FC::kDV, 3, true},
    InstructionForms{FC::kPA, "PA", L::kEmpty, L::kS32, L::kS32, AckForms::kBoth, FC::kDV, 4, true},
    InstructionForms{FC::kOG, "OG", L::kNone, L::kEmpty, L::kEmpty, AckForms::kBoth, FC::kOG, 0, false},
    InstructionForms{FC::kBL, "BL", L::kEmpty, L::kU32, L::kU32, AckForms::kBoth, FC::kBL, 0, false},
    InstructionForms{FC::kDV, "DV", L::kIndex, L::kNone, L::kIndexedS32, AckForms::kBoth, FC::kDV, 0, false},
    InstructionForms{FC::kIL, "IL", L::kIndex, L::kInputLogic, L::kInputLogic, AckForms::kBoth, FC::kIL, 0, false},
    InstructionForms{FC::kTG, "TG", L::kIndex, L::kIndexedWord, L::kIndexedWord, AckForms::kBoth, FC::kTG, 0, false},
    InstructionForms{FC::kDI, "DI", L::kEmpty, L::kDigitalOutput, L::kDigitalIo, AckForms::kBoth, FC::kDI, 0, false},
    InstructionForms{FC::kQE, "QE", L::kIndex, L::kIndexedWord, L::kIndexedWord, AckForms::kBoth, FC::kQE, 0, false},
    InstructionForms{FC::kSY, "SY", L::kNone, L::kIndex, L::kNone, AckForms::kNoAckOnly, FC::kSY, 0, false},
};

constexpr std::uint8_t kModelTable[][3] = {
    {0x20, 0x0A, 0x11}, {0x21, 0x0A, 0x11}, {0x22, 0x14, 0x13},
    {0x22, 0x28, 0x13}, {0x22, 0x50, 0x13}, {0x22, 0x50, 0x19},
};

bool is_input_port(std::uint8_t index) { return index <= static_cast<std::uint8_t>(InputPort::kIn3); }

// Writes `body` in `layout` into d0..; fails with body_mismatch when the body has another layout.
std::error_code write_body(Layout layout, const Body& body, std::span<std::uint8_t> d) {
  const auto mismatch = make_error_code(CodecErrc::kBodyMismatch);
  switch (layout) {
    case L::kNone: return make_error_code(CodecErrc::kFormNotSupported);
    case L::kEmpty:
    case L::kZeros4: return std::holds_alternative<Empty>(body) ? std::error_code{} : mismatch;
    case L::kIndex:
      if (const auto* b = std::get_if<Index>(&body)) {
        d[0] = b->index;
        return {};
      }
      return mismatch;
    case L::kByte:
      if (const auto* b = std::get_if<Byte>(&body)) {
        d[0] = b->value;
        return {};
      }
      return mismatch;
    case L::kIndexedByte:
      if (const auto* b = std::get_if<IndexedByte>(&body)) {
        d[0] = b->index;
        d[1] = b->value;
        return {};
      }
      return mismatch;
    case L::kInputLogic:
      if (const auto* b = std::get_if<InputActions>(&body); b && is_input_port(b->index)) {
        d[0] = b->index;
        d[1] = b->falling.byte();
        d[2] = b->rising.byte();
        return {};
      }
      // Only the non-port sub-indices (stall behaviour) carry a plain word.
      if (const auto* b = std::get_if<IndexedWord>(&body); !b || is_input_port(b->index)) return mismatch;
      [[fallthrough]];
    case L::kIndexedWord:
      if (const auto* b = std::get_if<IndexedWord>(&body)) {
        d[0] = b->index;
        bytes::write_le(d, 1, b->value);
        return {};
      }
      return mismatch;
    case L::kU32:
      if (const auto* b = std::get_if<Unsigned>(&body)) {
        bytes::write_le(d, 0, b->value);
        return {};
      }
      return mismatch;
    case L::kS32:
      if (const auto* b = std::get_if<Signed>(&body)) {
        bytes::write_le(d, 0, b->value);
        return {};
      }
      return mismatch;
    case L::kIndexedS32:
      if (const auto* b = std::get_if<IndexedSigned>(&body)) {
        d[0] = b->index;
        bytes::write_le(d, 1, b->value);
        return {};
      }
      return mismatch;
    case L::kDigitalOutput:
      if (const auto* b = std::get_if<DigitalOutput>(&body)) {
        d[0] = b->outputs;
        d[1] = b->write_enable;
        return {};
      }
      return mismatch;
    case L::kDigitalIo:
      if (const auto* b = std::get_if<DigitalIo>(&body)) {
        d[0] = b->inputs;
        d[1] = b->outputs;
        return {};
      }
      return mismatch;
    case L::kModel:
      if (const auto* b = std::get_if<ModelInfo>(&body)) {
        std::copy(b->model_bytes.begin(), b->model_bytes.end(), d.begin());
        bytes::write_le(d, 4, b->firmware);
        bytes::write_le(d, 6, b->factory);
        return {};
      }
      return mismatch;
    case L::kSerial:
      if (const auto* b = std::get_if<SerialNumber>(&body)) {
        bytes::write_le(d, 0, b->serial);
        bytes::write_le(d, 4, b->manufacturer);
        bytes::write_le(d, 6, b->vendor);
        return {};
      }
      return mismatch;
    case L::kErrorRecord:
      if (const auto* b = std::get_if<ErrorRecord>(&body)) {
        d[0] = b->index;
        d[1] = b->code;
        d[2] = b->control_word;
        d[3] = b->sub_index;
        d[4] = b->factory[0];
        d[5] = b->factory[1];
        return {};
      }
      return mismatch;
    case L::kMotionStatus:
      if (const auto* b = std::get_if<MotionStatus>(&body)) {
        d[0] = static_cast<std::uint8_t>(MotionStatusIndex::kStatus);
        d[1] = b->io_status;
        d[2] = b->flags;
        bytes::write_le(d, 4, b->relative_position);
        return {};
      }
      if (const auto* b = std::get_if<MotionKinematics>(&body)) {
        // The speed field is 24 bits wide: refuse rather than silently truncate.
        if (b->speed < -0x800000 || b->speed > 0x7FFFFF) return make_error_code(CodecErrc::kValueOutOfRange);
        d[0] = static_cast<std::uint8_t>(MotionStatusIndex::kKinematics);
        bytes::write_le<std::int32_t, 3>(d, 1, b->speed);
        bytes::write_le(d, 4, b->absolute_position);
        return {};
      }
      return mismatch;
  }
  return mismatch;
}

// Decodes exactly layout_length(layout) bytes (the caller checked the length).
Result<Body> read_body(Layout layout, std::span<const std::uint8_t> d) {
  const auto u16 = [d](std::size_t at) { return *bytes::read_le<std::uint16_t>(d, at); };
  const auto u32 = [d](std::size_t at) { return *bytes::read_le<std::uint32_t>(d, at); };
  const auto s32 = [d](std::size_t at) { return *bytes::read_le<std::int32_t>(d, at); };
  switch (layout) {
    case L::kNone: return CodecErrc::kFormNotSupported;
    case L::kEmpty:
    case L::kZeros4: return Body{Empty{}};
    case L::kIndex: return Body{Index{d[0]}};
    case L::kByte: return Body{Byte{d[0]}};
    case L::kIndexedByte: return Body{IndexedByte{d[0], d[1]}};
    case L::kInputLogic:
      if (is_input_port(d[0]))
        return Body{InputActions{d[0], EdgeAction::from_byte(d[1]), EdgeAction::from_byte(d[2])}};
      return Body{IndexedWord{d[0], u16(1)}};
    case L::kIndexedWord: return Body{IndexedWord{d[0], u16(1)}};
    case L::kU32: return Body{Unsigned{u32(0)}};
    case L::kS32: return Body{Signed{s32(0)}};
    case L::kIndexedS32: return Body{IndexedSigned{d[0], s32(1)}};
    case L::kDigitalOutput: return Body{DigitalOutput{d[0], d[1]}};
    case L::kDigitalIo: return Body{DigitalIo{d[0], d[1]}};
    case L::kModel: return Body{ModelInfo{{d[0], d[1], d[2], d[3]}, u16(4), u16(6)}};
    case L::kSerial: return Body{SerialNumber{u32(0), u16(4), u16(6)}};
    case L::kErrorRecord: return Body{ErrorRecord{d[0], d[1], d[2], d[3], {d[4], d[5]}}};
    case L::kMotionStatus:
      if (d[0] == static_cast<std::uint8_t>(MotionStatusIndex::kStatus)) return Body{MotionStatus{d[1], d[2], s32(4)}};
      if (d[0] == static_cast<std::uint8_t>(MotionStatusIndex::kKinematics)) {
        return Body{MotionKinematics{*bytes::read_le<std::int32_t, 3>(d, 1), s32(4)}};
      }
      return CodecErrc::kUnknownSubIndex;
  }
  return CodecErrc::kFormNotSupported;
}

Result<Message> encode_with(Layout layout, std::uint8_t control_word, const Body& body) {
  Message m;
  m.control_word = control_word;
  m.length = layout_length(layout);
  if (const auto error = write_body(layout, body, m.data)) return error;
  return m;
}

struct IndexVisitor {
  std::optional<std::uint8_t> operator()(const Index& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const IndexedByte& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const IndexedWord& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const InputActions& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const IndexedSigned& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const ErrorRecord& b) const { return b.index; }
  std::optional<std::uint8_t> operator()(const MotionStatus&) const { return std::uint8_t{0}; }
  std::optional<std::uint8_t> operator()(const MotionKinematics&) const { return std::uint8_t{1}; }
  std::optional<std::uint8_t> operator()(const auto&) const { return std::nullopt; }  // no sub-index
};

std::optional<std::uint8_t> index_of(const Body& body) { return std::visit(IndexVisitor{}, body); }

// "[i]" and the value part of the mnemonic notation.
std::string index_text(const Body& body) {
  const auto i = index_of(body);
  return i ? fmt::format("[{}]", *i) : std::string{};
}
std::string value_text(const Body& body) {
  struct Visitor {
    std::string operator()(const Empty&) const { return {}; }
    std::string operator()(const Index&) const { return {}; }
    std::string operator()(const Byte& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const IndexedByte& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const IndexedWord& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const InputActions& b) const {
      return fmt::format("0x{:02X},0x{:02X}", b.falling.byte(), b.rising.byte());
    }
    std::string operator()(const Unsigned& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const Signed& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const IndexedSigned& b) const { return fmt::format("{}", b.value); }
    std::string operator()(const DigitalOutput& b) const { return fmt::format("0x{:02X}", b.outputs); }
    std::string operator()(const DigitalIo& b) const {
      return fmt::format("in 0x{:02X} out 0x{:02X}", b.inputs, b.outputs);
    }
    std::string operator()(const ModelInfo& b) const {
      return fmt::format("{:02X} {:02X} {:02X} fw {}", b.model_bytes[0], b.model_bytes[1], b.model_bytes[2],
                         b.firmware);
    }
    std::string operator()(const SerialNumber& b) const {
      return fmt::format("sn {} mfr {} vendor {}", b.serial, b.manufacturer, b.vendor);
    }
    std::string operator()(const ErrorRecord& b) const {
      return fmt::format("0x{:02X} on CW 0x{:02X} [{}] ({})", b.code, b.control_word, b.sub_index, b.error().message());
    }
    std::string operator()(const MotionStatus& b) const {
      return fmt::format("status 0x{:02X} flags 0x{:02X} rel {}", b.io_status, b.flags, b.relative_position);
    }
    std::string operator()(const MotionKinematics& b) const {
      return fmt::format("speed {} abs {}", b.speed, b.absolute_position);
    }
  };
  return std::visit(Visitor{}, body);
}

Instruction make_get(FC f, Body body = Empty{}) { return {f, Operation::kGet, true, body}; }
Instruction make_set(FC f, Body body) { return {f, Operation::kSet, true, body}; }
std::uint8_t raw(auto e) { return static_cast<std::uint8_t>(e); }

}  // namespace

std::string_view mnemonic(FunctionCode f) noexcept {
  if (f == FC::kRT) return "RT";
  const auto* forms = find_forms(f);
  return forms ? forms->mnemonic : std::string_view{"??"};
}

std::optional<std::uint32_t> bits_per_second(BitRate rate) noexcept {
  switch (rate) {
    case BitRate::kKbps1000: return 1'000'000;
    case BitRate::kKbps800: return 800'000;
    case BitRate::kKbps500: return 500'000;
    case BitRate::kKbps250: return 250'000;
    case BitRate::kKbps125: return 125'000;
  }
  return std::nullopt;
}

Model ModelInfo::model() const noexcept {
  for (std::size_t i = 0; i < std::size(kModelTable); ++i) {
    if (std::equal(std::begin(kModelTable[i]), std::end(kModelTable[i]), model_bytes.begin())) {
      return static_cast<Model>(i + 1);  // Model lists the rows of §5.4 in table order after `unknown`
    }
  }
  return Model::kUnknown;
}

std::uint8_t layout_length(Layout layout) noexcept {
  switch (layout) {
    case L::kNone:
    case L::kEmpty: return 0;
    case L::kIndex:
    case L::kByte: return 1;
    case L::kIndexedByte: return 2;
    case L::kIndexedWord:
    case L::kInputLogic: return 3;
    case L::kZeros4:
    case L::kU32:
    case L::kS32:
    case L::kDigitalOutput:
    case L::kDigitalIo: return 4;
    case L::kIndexedS32: return 5;
    case L::kErrorRecord: return 6;
    case L::kModel:
    case L::kSerial:
    case L::kMotionStatus: return 8;
  }
  return 0;
}

std::span<const InstructionForms> instruction_table() noexcept { return kTable; }

const InstructionForms* find_forms(std::uint8_t function_code) noexcept {
  const auto* it = std::find_if(kTable.begin(), kTable.end(), [function_code](const InstructionForms& f) {
    return code(f.function) == function_code;
  });
  return it == kTable.end() ? nullptr : &*it;
}

std::optional<std::uint8_t> Instruction::sub_index() const { return index_of(body); }
std::optional<std::uint8_t> Reply::sub_index() const { return index_of(body); }

Result<Message> encode(const Instruction& instruction) {
  const auto* forms = find_forms(instruction.function);
  if (!forms) return CodecErrc::kUnknownFunction;
  if ((forms->ack_forms == AckForms::kAckOnly && !instruction.ack_requested) ||
      (forms->ack_forms == AckForms::kNoAckOnly && instruction.ack_requested)) {
    return CodecErrc::kAckFormNotSupported;
  }
  const Layout layout = instruction.operation == Operation::kGet ? forms->get : forms->set;
  return encode_with(layout, instruction.control_word(), instruction.body);
}

Result<Instruction> decode_instruction(const Message& message) {
  const auto* forms = find_forms(message.function_code());
  if (!forms) return CodecErrc::kUnknownFunction;
  // SY with bit 7 is executed like 0x7E (§5.8 lists no ACK form: assumed); ML without it does not
  // exist (§5.4).
  if (forms->ack_forms == AckForms::kAckOnly && !message.ack_requested()) return CodecErrc::kAckFormNotSupported;
  if (message.length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;

  Instruction out{forms->function, Operation::kGet, message.ack_requested(), Empty{}};
  const auto data = message.payload();
  Layout layout = L::kNone;
  std::array<std::uint8_t, kMaxDataLength> extended{};
  if (forms->get != L::kNone && message.length == layout_length(forms->get)) {
    layout = forms->get;
  } else if (forms->set != L::kNone && message.length == layout_length(forms->set)) {
    layout = forms->set;
    out.operation = Operation::kSet;
  } else if (forms->set_accepts_short && message.length >= 1 && message.length < layout_length(forms->set)) {
    layout = forms->set;  // §2.5 sends positive values in fewer bytes than §5.18-§5.21: zero-extended
    out.operation = Operation::kSet;
    std::copy(data.begin(), data.end(), extended.begin());
  } else {
    return CodecErrc::kWrongLength;
  }
  const auto body =
      read_body(layout, message.length < layout_length(layout) ? std::span<const std::uint8_t>(extended) : data);
  if (!body) return body.error();
  out.body = *body;
  return out;
}

Result<Message> encode(const Reply& reply) {
  const auto* forms = find_forms(reply.function);
  if (!forms) return CodecErrc::kUnknownFunction;
  return encode_with(forms->reply, code(reply.function), reply.body);
}

Result<Reply> decode_reply(const Message& message) {
  if (message.ack_requested()) return CodecErrc::kAckBitInReply;
  if (message.function_code() == code(FC::kRT)) return CodecErrc::kFormNotSupported;
  const auto* forms = find_forms(message.function_code());
  if (!forms) return CodecErrc::kUnknownFunction;
  if (forms->reply == L::kNone) return CodecErrc::kFormNotSupported;
  if (message.length > kMaxDataLength) return CodecErrc::kLengthOutOfRange;
  if (message.length != layout_length(forms->reply)) return CodecErrc::kWrongLength;
  const auto body = read_body(forms->reply, message.payload());
  if (!body) return body.error();
  return Reply{forms->function, *body};
}

Result<can::Frame> instruction_frame(std::uint8_t target, const Instruction& instruction, std::uint8_t host) {
  const auto message = encode(instruction);
  if (!message) return message.error();
  return encode_can({host_to(target, host), *message});
}

Result<can::Frame> reply_frame(std::uint8_t node, const Reply& reply, std::uint8_t host) {
  const auto message = encode(reply);
  if (!message) return message.error();
  return encode_can({drive_to_host(node, host), *message});
}

Result<AddressedInstruction> decode_instruction_frame(const can::Frame& frame) {
  const auto can_message = decode_can(frame);
  if (!can_message) return can_message.error();
  const auto instruction = decode_instruction(can_message->message);
  if (!instruction) return instruction.error();
  return AddressedInstruction{can_message->address, *instruction};
}

Result<AddressedReply> decode_reply_frame(const can::Frame& frame) {
  const auto can_message = decode_can(frame);
  if (!can_message) return can_message.error();
  const auto reply = decode_reply(can_message->message);
  if (!reply) return reply.error();
  return AddressedReply{can_message->address, *reply};
}

std::string to_string(const Instruction& instruction) {
  std::string out = fmt::format("{}{}", mnemonic(instruction.function), index_text(instruction.body));
  if (instruction.operation == Operation::kSet) {
    if (auto value = value_text(instruction.body); !value.empty()) out += "=" + value;
  }
  if (!instruction.ack_requested && instruction.function != FC::kSY) out += " (no ACK)";
  return out;
}

std::string to_string(const Reply& reply) {
  std::string out = fmt::format("{}{}", mnemonic(reply.function), index_text(reply.body));
  if (auto value = value_text(reply.body); !value.empty()) out += ": " + value;
  return out;
}

namespace request {
Instruction get(FunctionCode function) { return make_get(function); }
Instruction get(ProtocolParameter p) { return make_get(FC::kPP, Index{raw(p)}); }
Instruction get(InitialConfig c) { return make_get(FC::kIC, Index{raw(c)}); }
Instruction get(InformationEnable e) { return make_get(FC::kIE, Index{raw(e)}); }
Instruction get(QuadratureEncoder q) { return make_get(FC::kQE, Index{raw(q)}); }
Instruction get(MotorDriver m) { return make_get(FC::kMT, Index{raw(m)}); }
Instruction get(MotionStatusIndex s) { return make_get(FC::kMS, Index{raw(s)}); }
Instruction get(DesiredValue d) { return make_get(FC::kDV, Index{raw(d)}); }
Instruction get_error(std::uint8_t slot) { return make_get(FC::kER, Index{slot}); }
Instruction get_input_logic(std::uint8_t index) { return make_get(FC::kIL, Index{index}); }
Instruction get_trigger(InputPort port) { return make_get(FC::kTG, Index{raw(port)}); }

Instruction set(ProtocolParameter p, std::uint8_t value) { return make_set(FC::kPP, IndexedByte{raw(p), value}); }
Instruction set(InitialConfig c, std::uint16_t value) { return make_set(FC::kIC, IndexedWord{raw(c), value}); }
Instruction set(InformationEnable e, bool enabled) {
  return make_set(FC::kIE, IndexedWord{raw(e), static_cast<std::uint16_t>(enabled ? 1 : 0)});
}
Instruction set(QuadratureEncoder q, std::uint16_t value) { return make_set(FC::kQE, IndexedWord{raw(q), value}); }
Instruction set(MotorDriver m, std::uint16_t value) { return make_set(FC::kMT, IndexedWord{raw(m), value}); }
Instruction set_input_logic(InputPort port, EdgeAction falling, EdgeAction rising) {
  return make_set(FC::kIL, InputActions{raw(port), falling, rising});
}
Instruction set_stall_behaviour(StallBehaviour behaviour) {
  return make_set(FC::kIL, IndexedWord{kInputLogicStallBehaviour, raw(behaviour)});
}
Instruction set_trigger(InputPort port, std::uint16_t mode) { return make_set(FC::kTG, IndexedWord{raw(port), mode}); }
Instruction clear_error(std::uint8_t slot) { return make_set(FC::kER, IndexedByte{slot, 0}); }
Instruction clear_motion_status() { return make_set(FC::kMS, IndexedByte{raw(MotionStatusIndex::kStatus), 0}); }
Instruction driver_on(bool on) { return make_set(FC::kMO, Byte{static_cast<std::uint8_t>(on ? 1 : 0)}); }
Instruction select_group(ParameterGroup group) { return make_set(FC::kMF, Byte{raw(group)}); }
Instruction set_acceleration(std::uint32_t value) { return make_set(FC::kAC, Unsigned{value}); }
Instruction set_deceleration(std::uint32_t value) { return make_set(FC::kDC, Unsigned{value}); }
Instruction set_cut_in_speed(std::uint32_t pps) { return make_set(FC::kSS, Unsigned{pps}); }
Instruction set_stop_deceleration(std::uint32_t pps2) { return make_set(FC::kSD, Unsigned{pps2}); }
Instruction set_backlash(std::uint32_t pulses) { return make_set(FC::kBL, Unsigned{pulses}); }
Instruction set_jog_velocity(std::int32_t pps) { return make_set(FC::kJV, Signed{pps}); }
Instruction set_ptp_speed(std::int32_t pps) { return make_set(FC::kSP, Signed{pps}); }
Instruction set_relative_position(std::int32_t pulses) { return make_set(FC::kPR, Signed{pulses}); }
Instruction set_absolute_position(std::int32_t pulses) { return make_set(FC::kPA, Signed{pulses}); }
Instruction set_outputs(std::uint8_t outputs) { return make_set(FC::kDI, DigitalOutput{outputs, 1}); }
Instruction begin() { return make_set(FC::kBG, Empty{}); }
Instruction stop() { return make_set(FC::kST, Empty{}); }
Instruction set_origin() { return make_set(FC::kOG, Empty{}); }
Instruction system(SystemOperation op) { return {FC::kSY, Operation::kSet, false, Index{raw(op)}}; }
Instruction without_ack(Instruction instruction) {
  instruction.ack_requested = false;
  return instruction;
}
}  // namespace request

std::optional<Reply> echo_ack(const Instruction& set) {
  if (set.operation != Operation::kSet) return std::nullopt;
  const auto* forms = find_forms(set.function);
  if (!forms) return std::nullopt;
  if (forms->set_ack != forms->function) {
    const auto* value = std::get_if<Signed>(&set.body);
    if (!value) return std::nullopt;
    return Reply{forms->set_ack, IndexedSigned{forms->set_ack_index, value->value}};
  }
  if (set.function == FC::kER) {
    const auto* slot = std::get_if<IndexedByte>(&set.body);
    if (!slot) return std::nullopt;
    return Reply{FC::kER, ErrorRecord{slot->index, 0, 0, 0, {}}};
  }
  const bool same_layout = forms->set == forms->reply || (forms->set == L::kEmpty && forms->reply == L::kZeros4);
  if (!same_layout) return std::nullopt;
  return Reply{set.function, set.body};
}

Reply error_report(DriveErrc error, std::uint8_t received_control_word, std::uint8_t sub_index) {
  return Reply{FC::kER,
               ErrorRecord{kErrorSlotLatest, static_cast<std::uint8_t>(error), received_control_word, sub_index, {}}};
}

}  // namespace motion::uim342
