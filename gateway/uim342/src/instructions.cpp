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
    InstructionForms{FC::PP, "PP", L::index, L::indexed_byte, L::indexed_byte, AckForms::both, FC::PP, 0, false},
    InstructionForms{FC::IC, "IC", L::index, L::indexed_word, L::indexed_word, AckForms::both, FC::IC, 0, false},
    InstructionForms{FC::IE, "IE", L::index, L::indexed_word, L::indexed_word, AckForms::both, FC::IE, 0, false},
    InstructionForms{FC::ML, "ML", L::empty, L::none, L::model, AckForms::ack_only, FC::ML, 0, false},
    InstructionForms{FC::SN, "SN", L::empty, L::none, L::serial, AckForms::both, FC::SN, 0, false},
    InstructionForms{FC::ER, "ER", L::index, L::indexed_byte, L::error_record, AckForms::both, FC::ER, 0, false},
    InstructionForms{FC::MT, "MT", L::index, L::indexed_word, L::indexed_word, AckForms::both, FC::MT, 0, false},
    InstructionForms{FC::MS, "MS", L::index, L::indexed_byte, L::motion_status, AckForms::both, FC::MS, 0, false},
    InstructionForms{FC::MO, "MO", L::empty, L::byte, L::byte, AckForms::both, FC::MO, 0, false},
    InstructionForms{FC::BG, "BG", L::none, L::empty, L::zeros4, AckForms::both, FC::BG, 0, false},
    InstructionForms{FC::ST, "ST", L::none, L::empty, L::empty, AckForms::both, FC::ST, 0, false},
    InstructionForms{FC::MF, "MF", L::empty, L::byte, L::byte, AckForms::both, FC::MF, 0, false},
    InstructionForms{FC::AC, "AC", L::empty, L::u32, L::u32, AckForms::both, FC::AC, 0, false},
    InstructionForms{FC::DC, "DC", L::empty, L::u32, L::u32, AckForms::both, FC::DC, 0, false},
    InstructionForms{FC::SS, "SS", L::empty, L::u32, L::u32, AckForms::both, FC::SS, 0, false},
    InstructionForms{FC::SD, "SD", L::empty, L::u32, L::u32, AckForms::both, FC::SD, 0, false},
    InstructionForms{FC::JV, "JV", L::empty, L::s32, L::s32, AckForms::both, FC::DV, 2, true},
    InstructionForms{FC::SP, "SP", L::empty, L::s32, L::s32, AckForms::both, FC::DV, 2, true},
    InstructionForms{FC::PR, "PR", L::empty, L::s32, L::s32, AckForms::both, FC::DV, 3, true},
    InstructionForms{FC::PA, "PA", L::empty, L::s32, L::s32, AckForms::both, FC::DV, 4, true},
    InstructionForms{FC::OG, "OG", L::none, L::empty, L::empty, AckForms::both, FC::OG, 0, false},
    InstructionForms{FC::BL, "BL", L::empty, L::u32, L::u32, AckForms::both, FC::BL, 0, false},
    InstructionForms{FC::DV, "DV", L::index, L::none, L::indexed_s32, AckForms::both, FC::DV, 0, false},
    InstructionForms{FC::IL, "IL", L::index, L::input_logic, L::input_logic, AckForms::both, FC::IL, 0, false},
    InstructionForms{FC::TG, "TG", L::index, L::indexed_word, L::indexed_word, AckForms::both, FC::TG, 0, false},
    InstructionForms{FC::DI, "DI", L::empty, L::digital_output, L::digital_io, AckForms::both, FC::DI, 0, false},
    InstructionForms{FC::QE, "QE", L::index, L::indexed_word, L::indexed_word, AckForms::both, FC::QE, 0, false},
    InstructionForms{FC::SY, "SY", L::none, L::index, L::none, AckForms::no_ack_only, FC::SY, 0, false},
};

constexpr std::uint8_t kModelTable[][3] = {
    {0x20, 0x0A, 0x11}, {0x21, 0x0A, 0x11}, {0x22, 0x14, 0x13},
    {0x22, 0x28, 0x13}, {0x22, 0x50, 0x13}, {0x22, 0x50, 0x19},
};

bool is_input_port(std::uint8_t index) { return index <= static_cast<std::uint8_t>(InputPort::in3); }

// Writes `body` in `layout` into d0..; fails with body_mismatch when the body has another layout.
std::error_code write_body(Layout layout, const Body& body, std::span<std::uint8_t> d) {
  const auto mismatch = make_error_code(CodecErrc::body_mismatch);
  switch (layout) {
    case L::none: return make_error_code(CodecErrc::form_not_supported);
    case L::empty:
    case L::zeros4: return std::holds_alternative<Empty>(body) ? std::error_code{} : mismatch;
    case L::index:
      if (const auto* b = std::get_if<Index>(&body)) {
        d[0] = b->index;
        return {};
      }
      return mismatch;
    case L::byte:
      if (const auto* b = std::get_if<Byte>(&body)) {
        d[0] = b->value;
        return {};
      }
      return mismatch;
    case L::indexed_byte:
      if (const auto* b = std::get_if<IndexedByte>(&body)) {
        d[0] = b->index;
        d[1] = b->value;
        return {};
      }
      return mismatch;
    case L::input_logic:
      if (const auto* b = std::get_if<InputActions>(&body); b && is_input_port(b->index)) {
        d[0] = b->index;
        d[1] = b->falling.byte();
        d[2] = b->rising.byte();
        return {};
      }
      // Only the non-port sub-indices (stall behaviour) carry a plain word.
      if (const auto* b = std::get_if<IndexedWord>(&body); !b || is_input_port(b->index)) return mismatch;
      [[fallthrough]];
    case L::indexed_word:
      if (const auto* b = std::get_if<IndexedWord>(&body)) {
        d[0] = b->index;
        bytes::write_le(d, 1, b->value);
        return {};
      }
      return mismatch;
    case L::u32:
      if (const auto* b = std::get_if<Unsigned>(&body)) {
        bytes::write_le(d, 0, b->value);
        return {};
      }
      return mismatch;
    case L::s32:
      if (const auto* b = std::get_if<Signed>(&body)) {
        bytes::write_le(d, 0, b->value);
        return {};
      }
      return mismatch;
    case L::indexed_s32:
      if (const auto* b = std::get_if<IndexedSigned>(&body)) {
        d[0] = b->index;
        bytes::write_le(d, 1, b->value);
        return {};
      }
      return mismatch;
    case L::digital_output:
      if (const auto* b = std::get_if<DigitalOutput>(&body)) {
        d[0] = b->outputs;
        d[1] = b->write_enable;
        return {};
      }
      return mismatch;
    case L::digital_io:
      if (const auto* b = std::get_if<DigitalIo>(&body)) {
        d[0] = b->inputs;
        d[1] = b->outputs;
        return {};
      }
      return mismatch;
    case L::model:
      if (const auto* b = std::get_if<ModelInfo>(&body)) {
        std::copy(b->model_bytes.begin(), b->model_bytes.end(), d.begin());
        bytes::write_le(d, 4, b->firmware);
        bytes::write_le(d, 6, b->factory);
        return {};
      }
      return mismatch;
    case L::serial:
      if (const auto* b = std::get_if<SerialNumber>(&body)) {
        bytes::write_le(d, 0, b->serial);
        bytes::write_le(d, 4, b->manufacturer);
        bytes::write_le(d, 6, b->vendor);
        return {};
      }
      return mismatch;
    case L::error_record:
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
    case L::motion_status:
      if (const auto* b = std::get_if<MotionStatus>(&body)) {
        d[0] = static_cast<std::uint8_t>(MotionStatusIndex::status);
        d[1] = b->io_status;
        d[2] = b->flags;
        bytes::write_le(d, 4, b->relative_position);
        return {};
      }
      if (const auto* b = std::get_if<MotionKinematics>(&body)) {
        // The speed field is 24 bits wide: refuse rather than silently truncate.
        if (b->speed < -0x800000 || b->speed > 0x7FFFFF) return make_error_code(CodecErrc::value_out_of_range);
        d[0] = static_cast<std::uint8_t>(MotionStatusIndex::kinematics);
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
    case L::none: return CodecErrc::form_not_supported;
    case L::empty:
    case L::zeros4: return Body{Empty{}};
    case L::index: return Body{Index{d[0]}};
    case L::byte: return Body{Byte{d[0]}};
    case L::indexed_byte: return Body{IndexedByte{d[0], d[1]}};
    case L::input_logic:
      if (is_input_port(d[0]))
        return Body{InputActions{d[0], EdgeAction::from_byte(d[1]), EdgeAction::from_byte(d[2])}};
      return Body{IndexedWord{d[0], u16(1)}};
    case L::indexed_word: return Body{IndexedWord{d[0], u16(1)}};
    case L::u32: return Body{Unsigned{u32(0)}};
    case L::s32: return Body{Signed{s32(0)}};
    case L::indexed_s32: return Body{IndexedSigned{d[0], s32(1)}};
    case L::digital_output: return Body{DigitalOutput{d[0], d[1]}};
    case L::digital_io: return Body{DigitalIo{d[0], d[1]}};
    case L::model: return Body{ModelInfo{{d[0], d[1], d[2], d[3]}, u16(4), u16(6)}};
    case L::serial: return Body{SerialNumber{u32(0), u16(4), u16(6)}};
    case L::error_record: return Body{ErrorRecord{d[0], d[1], d[2], d[3], {d[4], d[5]}}};
    case L::motion_status:
      if (d[0] == static_cast<std::uint8_t>(MotionStatusIndex::status)) return Body{MotionStatus{d[1], d[2], s32(4)}};
      if (d[0] == static_cast<std::uint8_t>(MotionStatusIndex::kinematics)) {
        return Body{MotionKinematics{*bytes::read_le<std::int32_t, 3>(d, 1), s32(4)}};
      }
      return CodecErrc::unknown_sub_index;
  }
  return CodecErrc::form_not_supported;
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

Instruction make_get(FC f, Body body = Empty{}) { return {f, Operation::get, true, body}; }
Instruction make_set(FC f, Body body) { return {f, Operation::set, true, body}; }
std::uint8_t raw(auto e) { return static_cast<std::uint8_t>(e); }

}  // namespace

std::string_view mnemonic(FunctionCode f) noexcept {
  if (f == FC::RT) return "RT";
  const auto* forms = find_forms(f);
  return forms ? forms->mnemonic : std::string_view{"??"};
}

std::optional<std::uint32_t> bits_per_second(BitRate rate) noexcept {
  switch (rate) {
    case BitRate::kbps_1000: return 1'000'000;
    case BitRate::kbps_800: return 800'000;
    case BitRate::kbps_500: return 500'000;
    case BitRate::kbps_250: return 250'000;
    case BitRate::kbps_125: return 125'000;
  }
  return std::nullopt;
}

Model ModelInfo::model() const noexcept {
  for (std::size_t i = 0; i < std::size(kModelTable); ++i) {
    if (std::equal(std::begin(kModelTable[i]), std::end(kModelTable[i]), model_bytes.begin())) {
      return static_cast<Model>(i + 1);  // Model lists the rows of §5.4 in table order after `unknown`
    }
  }
  return Model::unknown;
}

std::uint8_t layout_length(Layout layout) noexcept {
  switch (layout) {
    case L::none:
    case L::empty: return 0;
    case L::index:
    case L::byte: return 1;
    case L::indexed_byte: return 2;
    case L::indexed_word:
    case L::input_logic: return 3;
    case L::zeros4:
    case L::u32:
    case L::s32:
    case L::digital_output:
    case L::digital_io: return 4;
    case L::indexed_s32: return 5;
    case L::error_record: return 6;
    case L::model:
    case L::serial:
    case L::motion_status: return 8;
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
  if (!forms) return CodecErrc::unknown_function;
  if ((forms->ack_forms == AckForms::ack_only && !instruction.ack_requested) ||
      (forms->ack_forms == AckForms::no_ack_only && instruction.ack_requested)) {
    return CodecErrc::ack_form_not_supported;
  }
  const Layout layout = instruction.operation == Operation::get ? forms->get : forms->set;
  return encode_with(layout, instruction.control_word(), instruction.body);
}

Result<Instruction> decode_instruction(const Message& message) {
  const auto* forms = find_forms(message.function_code());
  if (!forms) return CodecErrc::unknown_function;
  // SY with bit 7 is executed like 0x7E (§5.8 lists no ACK form: assumed); ML without it does not
  // exist (§5.4).
  if (forms->ack_forms == AckForms::ack_only && !message.ack_requested()) return CodecErrc::ack_form_not_supported;
  if (message.length > kMaxDataLength) return CodecErrc::length_out_of_range;

  Instruction out{forms->function, Operation::get, message.ack_requested(), Empty{}};
  const auto data = message.payload();
  Layout layout = L::none;
  std::array<std::uint8_t, kMaxDataLength> extended{};
  if (forms->get != L::none && message.length == layout_length(forms->get)) {
    layout = forms->get;
  } else if (forms->set != L::none && message.length == layout_length(forms->set)) {
    layout = forms->set;
    out.operation = Operation::set;
  } else if (forms->set_accepts_short && message.length >= 1 && message.length < layout_length(forms->set)) {
    layout = forms->set;  // §2.5 sends positive values in fewer bytes than §5.18-§5.21: zero-extended
    out.operation = Operation::set;
    std::copy(data.begin(), data.end(), extended.begin());
  } else {
    return CodecErrc::wrong_length;
  }
  const auto body =
      read_body(layout, message.length < layout_length(layout) ? std::span<const std::uint8_t>(extended) : data);
  if (!body) return body.error();
  out.body = *body;
  return out;
}

Result<Message> encode(const Reply& reply) {
  const auto* forms = find_forms(reply.function);
  if (!forms) return CodecErrc::unknown_function;
  return encode_with(forms->reply, code(reply.function), reply.body);
}

Result<Reply> decode_reply(const Message& message) {
  if (message.ack_requested()) return CodecErrc::ack_bit_in_reply;
  if (message.function_code() == code(FC::RT)) return CodecErrc::form_not_supported;
  const auto* forms = find_forms(message.function_code());
  if (!forms) return CodecErrc::unknown_function;
  if (forms->reply == L::none) return CodecErrc::form_not_supported;
  if (message.length > kMaxDataLength) return CodecErrc::length_out_of_range;
  if (message.length != layout_length(forms->reply)) return CodecErrc::wrong_length;
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
  if (instruction.operation == Operation::set) {
    if (auto value = value_text(instruction.body); !value.empty()) out += "=" + value;
  }
  if (!instruction.ack_requested && instruction.function != FC::SY) out += " (no ACK)";
  return out;
}

std::string to_string(const Reply& reply) {
  std::string out = fmt::format("{}{}", mnemonic(reply.function), index_text(reply.body));
  if (auto value = value_text(reply.body); !value.empty()) out += ": " + value;
  return out;
}

namespace request {
Instruction get(FunctionCode function) { return make_get(function); }
Instruction get(ProtocolParameter p) { return make_get(FC::PP, Index{raw(p)}); }
Instruction get(InitialConfig c) { return make_get(FC::IC, Index{raw(c)}); }
Instruction get(InformationEnable e) { return make_get(FC::IE, Index{raw(e)}); }
Instruction get(QuadratureEncoder q) { return make_get(FC::QE, Index{raw(q)}); }
Instruction get(MotorDriver m) { return make_get(FC::MT, Index{raw(m)}); }
Instruction get(MotionStatusIndex s) { return make_get(FC::MS, Index{raw(s)}); }
Instruction get(DesiredValue d) { return make_get(FC::DV, Index{raw(d)}); }
Instruction get_error(std::uint8_t slot) { return make_get(FC::ER, Index{slot}); }
Instruction get_input_logic(std::uint8_t index) { return make_get(FC::IL, Index{index}); }
Instruction get_trigger(InputPort port) { return make_get(FC::TG, Index{raw(port)}); }

Instruction set(ProtocolParameter p, std::uint8_t value) { return make_set(FC::PP, IndexedByte{raw(p), value}); }
Instruction set(InitialConfig c, std::uint16_t value) { return make_set(FC::IC, IndexedWord{raw(c), value}); }
Instruction set(InformationEnable e, bool enabled) {
  return make_set(FC::IE, IndexedWord{raw(e), static_cast<std::uint16_t>(enabled ? 1 : 0)});
}
Instruction set(QuadratureEncoder q, std::uint16_t value) { return make_set(FC::QE, IndexedWord{raw(q), value}); }
Instruction set(MotorDriver m, std::uint16_t value) { return make_set(FC::MT, IndexedWord{raw(m), value}); }
Instruction set_input_logic(InputPort port, EdgeAction falling, EdgeAction rising) {
  return make_set(FC::IL, InputActions{raw(port), falling, rising});
}
Instruction set_stall_behaviour(StallBehaviour behaviour) {
  return make_set(FC::IL, IndexedWord{kInputLogicStallBehaviour, raw(behaviour)});
}
Instruction set_trigger(InputPort port, std::uint16_t mode) { return make_set(FC::TG, IndexedWord{raw(port), mode}); }
Instruction clear_error(std::uint8_t slot) { return make_set(FC::ER, IndexedByte{slot, 0}); }
Instruction clear_motion_status() { return make_set(FC::MS, IndexedByte{raw(MotionStatusIndex::status), 0}); }
Instruction driver_on(bool on) { return make_set(FC::MO, Byte{static_cast<std::uint8_t>(on ? 1 : 0)}); }
Instruction select_group(ParameterGroup group) { return make_set(FC::MF, Byte{raw(group)}); }
Instruction set_acceleration(std::uint32_t value) { return make_set(FC::AC, Unsigned{value}); }
Instruction set_deceleration(std::uint32_t value) { return make_set(FC::DC, Unsigned{value}); }
Instruction set_cut_in_speed(std::uint32_t pps) { return make_set(FC::SS, Unsigned{pps}); }
Instruction set_stop_deceleration(std::uint32_t pps2) { return make_set(FC::SD, Unsigned{pps2}); }
Instruction set_backlash(std::uint32_t pulses) { return make_set(FC::BL, Unsigned{pulses}); }
Instruction set_jog_velocity(std::int32_t pps) { return make_set(FC::JV, Signed{pps}); }
Instruction set_ptp_speed(std::int32_t pps) { return make_set(FC::SP, Signed{pps}); }
Instruction set_relative_position(std::int32_t pulses) { return make_set(FC::PR, Signed{pulses}); }
Instruction set_absolute_position(std::int32_t pulses) { return make_set(FC::PA, Signed{pulses}); }
Instruction set_outputs(std::uint8_t outputs) { return make_set(FC::DI, DigitalOutput{outputs, 1}); }
Instruction begin() { return make_set(FC::BG, Empty{}); }
Instruction stop() { return make_set(FC::ST, Empty{}); }
Instruction set_origin() { return make_set(FC::OG, Empty{}); }
Instruction system(SystemOperation op) { return {FC::SY, Operation::set, false, Index{raw(op)}}; }
Instruction without_ack(Instruction instruction) {
  instruction.ack_requested = false;
  return instruction;
}
}  // namespace request

std::optional<Reply> echo_ack(const Instruction& set) {
  if (set.operation != Operation::set) return std::nullopt;
  const auto* forms = find_forms(set.function);
  if (!forms) return std::nullopt;
  if (forms->set_ack != forms->function) {
    const auto* value = std::get_if<Signed>(&set.body);
    if (!value) return std::nullopt;
    return Reply{forms->set_ack, IndexedSigned{forms->set_ack_index, value->value}};
  }
  if (set.function == FC::ER) {
    const auto* slot = std::get_if<IndexedByte>(&set.body);
    if (!slot) return std::nullopt;
    return Reply{FC::ER, ErrorRecord{slot->index, 0, 0, 0, {}}};
  }
  const bool same_layout = forms->set == forms->reply || (forms->set == L::empty && forms->reply == L::zeros4);
  if (!same_layout) return std::nullopt;
  return Reply{set.function, set.body};
}

Reply error_report(DriveErrc error, std::uint8_t received_control_word, std::uint8_t sub_index) {
  return Reply{FC::ER,
               ErrorRecord{kErrorSlotLatest, static_cast<std::uint8_t>(error), received_control_word, sub_index, {}}};
}

}  // namespace motion::uim342
