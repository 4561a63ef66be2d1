// CiA 301 §7.2.4.3 SDO protocol codec: initiate/segment download and upload (expedited with or
// without size indication, segmented) and abort, for both directions. Block transfer is not
// supported (the UC57 does not offer it); its command specifiers decode as nullopt.
//
// An expedited initiate with size indication and no data cannot be expressed (n has two bits);
// the encoder sends it as a segmented initiate announcing 0 bytes.
//
// Every SDO frame has DLC 8 (CiA 301 §7.2.4.3); decoders reject any other length. Bits and bytes
// CiA 301 declares unused ("x" bits, padding after the data) are written as 0 and ignored when
// read, as lely-core and CANopenNode do. Pure functions, thread-safe.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <span>
#include <variant>

#include "motion/can_frame/frame.hpp"
#include "motion/canopen/types.hpp"

namespace motion::canopen {

inline constexpr std::size_t kSdoFrameSize = 8;
inline constexpr std::size_t kSdoExpeditedMax = 4;
inline constexpr std::size_t kSdoSegmentMax = 7;

// Byte 0 bits 7..5 of a request (client command specifier).
enum class SdoClientCommand : std::uint8_t {
  kDownloadSegment = 0,
  kInitiateDownload = 1,
  kInitiateUpload = 2,
  kUploadSegment = 3,
  kAbort = 4,
  kBlockUpload = 5,
  kBlockDownload = 6,
};

// Byte 0 bits 7..5 of a response (server command specifier).
enum class SdoServerCommand : std::uint8_t {
  kUploadSegment = 0,
  kDownloadSegment = 1,
  kInitiateUpload = 2,
  kInitiateDownload = 3,
  kAbort = 4,
  kBlockDownload = 5,
  kBlockUpload = 6,
};

// The initiate frame that carries data or a size: initiate download request (ccs 1) and
// initiate upload response (scs 2) share this layout.
struct SdoInitiateData {
  ObjectAddress object;
  bool expedited = false;
  bool size_indicated = false;
  // Expedited: the data (1..4 bytes when size_indicated, else 4 bytes whose meaningful length
  // only the object's type tells). Segmented: empty.
  InlineBytes<kSdoExpeditedMax> data;
  // Segmented with size_indicated: the total byte count. Unused otherwise.
  std::uint32_t total_size = 0;

  [[nodiscard]] static SdoInitiateData expedited_data(ObjectAddress object, InlineBytes<kSdoExpeditedMax> data) {
    return {object, true, true, data, 0};
  }
  [[nodiscard]] static SdoInitiateData segmented(ObjectAddress object, std::uint32_t total_size) {
    return {object, false, true, {}, total_size};
  }
  friend bool operator==(const SdoInitiateData&, const SdoInitiateData&) = default;
};

// A segment frame that carries data: download segment request (ccs 0), upload segment response
// (scs 0). `data` holds 0..7 bytes.
struct SdoSegmentData {
  bool toggle = false;
  bool last = false;
  InlineBytes<kSdoSegmentMax> data;
  friend bool operator==(const SdoSegmentData&, const SdoSegmentData&) = default;
};

struct SdoInitiateDownloadRequest : SdoInitiateData {};
struct SdoDownloadSegmentRequest : SdoSegmentData {};
struct SdoInitiateUploadRequest {
  ObjectAddress object;
  friend constexpr bool operator==(const SdoInitiateUploadRequest&, const SdoInitiateUploadRequest&) = default;
};
struct SdoUploadSegmentRequest {
  bool toggle = false;
  friend constexpr bool operator==(const SdoUploadSegmentRequest&, const SdoUploadSegmentRequest&) = default;
};

struct SdoInitiateDownloadResponse {
  ObjectAddress object;
  friend constexpr bool operator==(const SdoInitiateDownloadResponse&, const SdoInitiateDownloadResponse&) = default;
};
struct SdoDownloadSegmentResponse {
  bool toggle = false;
  friend constexpr bool operator==(const SdoDownloadSegmentResponse&, const SdoDownloadSegmentResponse&) = default;
};
struct SdoInitiateUploadResponse : SdoInitiateData {};
struct SdoUploadSegmentResponse : SdoSegmentData {};

// Either direction. `code` is the raw 32-bit abort code (see SdoAbortCode).
struct SdoAbort {
  ObjectAddress object;
  std::uint32_t code = 0;
  friend constexpr bool operator==(const SdoAbort&, const SdoAbort&) = default;
};

using SdoRequest = std::variant<SdoInitiateDownloadRequest, SdoDownloadSegmentRequest, SdoInitiateUploadRequest,
                                SdoUploadSegmentRequest, SdoAbort>;
using SdoResponse = std::variant<SdoInitiateDownloadResponse, SdoDownloadSegmentResponse, SdoInitiateUploadResponse,
                                 SdoUploadSegmentResponse, SdoAbort>;

using SdoPayload = std::array<std::uint8_t, kSdoFrameSize>;

[[nodiscard]] SdoPayload encode_sdo_request(const SdoRequest& request);
[[nodiscard]] SdoPayload encode_sdo_response(const SdoResponse& response);
// nullopt: not 8 bytes, or an unknown or block-transfer command specifier.
[[nodiscard]] std::optional<SdoRequest> decode_sdo_request(std::span<const std::uint8_t> payload);
[[nodiscard]] std::optional<SdoResponse> decode_sdo_response(std::span<const std::uint8_t> payload);

// Frames on the default SDO channel of `node` (600h + n requests, 580h + n responses).
[[nodiscard]] can::Frame sdo_request_frame(NodeId node, const SdoRequest& request);
[[nodiscard]] can::Frame sdo_response_frame(NodeId node, const SdoResponse& response);

}  // namespace motion::canopen
