#include "motion/canopen/sdo.hpp"

#include "frame_util.hpp"
#include "motion/canopen/cob_id.hpp"
#include "motion/core/bytes.hpp"

namespace motion::canopen {
namespace {

// Byte 0 bit fields (CiA 301 §7.2.4.3.3 ff.).
constexpr std::uint8_t kSizeIndicatedBit = 0x01;  // s (initiate)
constexpr std::uint8_t kExpeditedBit = 0x02;      // e (initiate)
constexpr std::uint8_t kLastSegmentBit = 0x01;    // c (segment)
constexpr std::uint8_t kToggleBit = 0x10;         // t (segment)

constexpr std::uint8_t command_byte(std::uint8_t specifier) { return static_cast<std::uint8_t>(specifier << 5); }
constexpr std::uint8_t specifier_of(std::uint8_t byte0) { return static_cast<std::uint8_t>(byte0 >> 5); }
constexpr std::uint8_t toggle_bit(bool toggle) { return toggle ? kToggleBit : std::uint8_t{0}; }

void put_object(SdoPayload& out, ObjectAddress object) {
  bytes::write_le<std::uint16_t>(out, 1, object.index);
  out[3] = object.subindex;
}

ObjectAddress object_of(std::span<const std::uint8_t> in) { return {*bytes::read_le<std::uint16_t>(in, 1), in[3]}; }

SdoPayload encode_initiate(std::uint8_t specifier, const SdoInitiateData& message) {
  SdoPayload out{};
  std::uint8_t byte0 = command_byte(specifier);
  // n has two bits (0..3 unused bytes): an empty value cannot be sent expedited with its size;
  // it goes out as a segmented initiate announcing 0 bytes instead of a frame whose n overflows
  // into the reserved bit 4.
  if (message.expedited && message.size_indicated && message.data.empty()) {
    return encode_initiate(specifier, SdoInitiateData::segmented(message.object, 0));
  }
  if (message.expedited) {
    byte0 |= kExpeditedBit;
    if (message.size_indicated) {
      byte0 |= kSizeIndicatedBit;
      byte0 |= static_cast<std::uint8_t>((kSdoExpeditedMax - message.data.size()) << 2);
    }
    std::copy(message.data.view().begin(), message.data.view().end(), out.begin() + 4);
  } else if (message.size_indicated) {
    byte0 |= kSizeIndicatedBit;
    bytes::write_le<std::uint32_t>(out, 4, message.total_size);
  }
  out[0] = byte0;
  put_object(out, message.object);
  return out;
}

SdoInitiateData decode_initiate(std::span<const std::uint8_t> in) {
  SdoInitiateData message;
  message.object = object_of(in);
  message.expedited = (in[0] & kExpeditedBit) != 0;
  message.size_indicated = (in[0] & kSizeIndicatedBit) != 0;
  if (message.expedited) {
    const std::size_t unused = message.size_indicated ? ((in[0] >> 2) & 0x03u) : 0;
    message.data = *InlineBytes<kSdoExpeditedMax>::from(in.subspan(4, kSdoExpeditedMax - unused));
  } else if (message.size_indicated) {
    message.total_size = *bytes::read_le<std::uint32_t>(in, 4);
  }
  return message;
}

SdoPayload encode_segment(std::uint8_t specifier, const SdoSegmentData& message) {
  SdoPayload out{};
  out[0] =
      static_cast<std::uint8_t>(command_byte(specifier) | toggle_bit(message.toggle) |
                                ((kSdoSegmentMax - message.data.size()) << 1) | (message.last ? kLastSegmentBit : 0u));
  std::copy(message.data.view().begin(), message.data.view().end(), out.begin() + 1);
  return out;
}

SdoSegmentData decode_segment(std::span<const std::uint8_t> in) {
  SdoSegmentData message;
  message.toggle = (in[0] & kToggleBit) != 0;
  message.last = (in[0] & kLastSegmentBit) != 0;
  const std::size_t unused = (in[0] >> 1) & 0x07u;
  message.data = *InlineBytes<kSdoSegmentMax>::from(in.subspan(1, kSdoSegmentMax - unused));
  return message;
}

// Command-only frames: the specifier, optionally the toggle, optionally the multiplexer.
SdoPayload encode_toggle_only(std::uint8_t specifier, bool toggle) {
  SdoPayload out{};
  out[0] = static_cast<std::uint8_t>(command_byte(specifier) | toggle_bit(toggle));
  return out;
}

SdoPayload encode_object_only(std::uint8_t specifier, ObjectAddress object) {
  SdoPayload out{};
  out[0] = command_byte(specifier);
  put_object(out, object);
  return out;
}

SdoPayload encode_abort(const SdoAbort& abort) {
  SdoPayload out = encode_object_only(static_cast<std::uint8_t>(SdoClientCommand::kAbort), abort.object);
  bytes::write_le<std::uint32_t>(out, 4, abort.code);
  return out;
}

SdoAbort decode_abort(std::span<const std::uint8_t> in) {
  return {object_of(in), *bytes::read_le<std::uint32_t>(in, 4)};
}

template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;  // clang 14 has no CTAD for aggregates

}  // namespace

SdoPayload encode_sdo_request(const SdoRequest& request) {
  constexpr auto spec = [](SdoClientCommand c) { return static_cast<std::uint8_t>(c); };
  return std::visit(Overloaded{
                        [&](const SdoInitiateDownloadRequest& m) {
                          return encode_initiate(spec(SdoClientCommand::kInitiateDownload), m);
                        },
                        [&](const SdoDownloadSegmentRequest& m) {
                          return encode_segment(spec(SdoClientCommand::kDownloadSegment), m);
                        },
                        [&](const SdoInitiateUploadRequest& m) {
                          return encode_object_only(spec(SdoClientCommand::kInitiateUpload), m.object);
                        },
                        [&](const SdoUploadSegmentRequest& m) {
                          return encode_toggle_only(spec(SdoClientCommand::kUploadSegment), m.toggle);
                        },
                        [&](const SdoAbort& m) { return encode_abort(m); },
                    },
                    request);
}

SdoPayload encode_sdo_response(const SdoResponse& response) {
  constexpr auto spec = [](SdoServerCommand c) { return static_cast<std::uint8_t>(c); };
  return std::visit(
      Overloaded{
          [&](const SdoInitiateDownloadResponse& m) {
            return encode_object_only(spec(SdoServerCommand::kInitiateDownload), m.object);
          },
          [&](const SdoDownloadSegmentResponse& m) {
            return encode_toggle_only(spec(SdoServerCommand::kDownloadSegment), m.toggle);
          },
          [&](const SdoInitiateUploadResponse& m) {
            return encode_initiate(spec(SdoServerCommand::kInitiateUpload), m);
          },
          [&](const SdoUploadSegmentResponse& m) { return encode_segment(spec(SdoServerCommand::kUploadSegment), m); },
          [&](const SdoAbort& m) { return encode_abort(m); },
      },
      response);
}

std::optional<SdoRequest> decode_sdo_request(std::span<const std::uint8_t> in) {
  if (in.size() != kSdoFrameSize) return std::nullopt;
  switch (static_cast<SdoClientCommand>(specifier_of(in[0]))) {
    case SdoClientCommand::kDownloadSegment: return SdoDownloadSegmentRequest{decode_segment(in)};
    case SdoClientCommand::kInitiateDownload: return SdoInitiateDownloadRequest{decode_initiate(in)};
    case SdoClientCommand::kInitiateUpload: return SdoInitiateUploadRequest{object_of(in)};
    case SdoClientCommand::kUploadSegment: return SdoUploadSegmentRequest{(in[0] & kToggleBit) != 0};
    case SdoClientCommand::kAbort: return decode_abort(in);
    case SdoClientCommand::kBlockUpload:
    case SdoClientCommand::kBlockDownload: break;
  }
  return std::nullopt;
}

std::optional<SdoResponse> decode_sdo_response(std::span<const std::uint8_t> in) {
  if (in.size() != kSdoFrameSize) return std::nullopt;
  switch (static_cast<SdoServerCommand>(specifier_of(in[0]))) {
    case SdoServerCommand::kUploadSegment: return SdoUploadSegmentResponse{decode_segment(in)};
    case SdoServerCommand::kDownloadSegment: return SdoDownloadSegmentResponse{(in[0] & kToggleBit) != 0};
    case SdoServerCommand::kInitiateUpload: return SdoInitiateUploadResponse{decode_initiate(in)};
    case SdoServerCommand::kInitiateDownload: return SdoInitiateDownloadResponse{object_of(in)};
    case SdoServerCommand::kAbort: return decode_abort(in);
    case SdoServerCommand::kBlockDownload:
    case SdoServerCommand::kBlockUpload: break;
  }
  return std::nullopt;
}

can::Frame sdo_request_frame(NodeId node, const SdoRequest& request) {
  return detail::standard_frame(sdo_request_cob_id(node), encode_sdo_request(request));
}

can::Frame sdo_response_frame(NodeId node, const SdoResponse& response) {
  return detail::standard_frame(sdo_response_cob_id(node), encode_sdo_response(response));
}

}  // namespace motion::canopen
