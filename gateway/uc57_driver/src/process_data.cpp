#include "motion/uc57_driver/process_data.hpp"

#include <array>

#include "motion/canopen/cob_id.hpp"
#include "motion/cia402/uc57_od.hpp"
#include "motion/uc57_driver/node_settings.hpp"

namespace motion::uc57_driver {
namespace {

namespace od = cia402::uc57::index;

constexpr canopen::PdoMappingEntry kControlwordEntry{od::kControlword, 0, 16};
constexpr canopen::PdoMappingEntry kTargetPositionEntry{od::kTargetPosition, 0, 32};
constexpr canopen::PdoMappingEntry kTargetVelocityEntry{od::kTargetVelocity, 0, 32};
constexpr canopen::PdoMappingEntry kModeEntry{od::kModesOfOperation, 0, 8};

can::Frame pdo_frame(std::uint32_t cob_id, const canopen::PdoMapping& mapping, std::span<const std::uint64_t> values) {
  const auto payload = canopen::pack_pdo(mapping, values);
  // The mappings here are fixed and every value is truncated to its width below: packing cannot fail.
  return *can::Frame::make(cob_id, false, payload ? payload->view() : std::span<const std::uint8_t>{});
}

// Two's complement of a signed value, as pack_pdo expects negative numbers.
std::uint64_t raw(std::int64_t value) { return static_cast<std::uint64_t>(value); }

}  // namespace

canopen::PdoMapping rpdo1_mapping(RpdoLayout layout) {
  if (layout == RpdoLayout::kControlwordTarget) return {kControlwordEntry, kTargetPositionEntry};
  return {kControlwordEntry, kTargetVelocityEntry, kModeEntry};
}

canopen::PdoConfiguration rpdo1_remap(canopen::NodeId node, std::uint8_t transmission_type) {
  canopen::PdoConfiguration config;
  config.direction = canopen::PdoDirection::kReceive;
  config.number = 1;
  config.cob_id = canopen::rpdo_cob_id(1, node);
  config.transmission_type = transmission_type;
  config.mapping = rpdo1_mapping(RpdoLayout::kControlwordTarget);
  return config;
}

can::Frame encode_rpdo1(canopen::NodeId node, RpdoLayout layout, const RpdoImage& image) {
  const auto mapping = rpdo1_mapping(layout);
  if (layout == RpdoLayout::kControlwordTarget) {
    const std::array<std::uint64_t, 2> values{image.controlword, raw(image.target_position)};
    return pdo_frame(canopen::rpdo_cob_id(1, node), mapping, values);
  }
  const std::array<std::uint64_t, 3> values{image.controlword, raw(image.target_velocity), raw(image.mode)};
  return pdo_frame(canopen::rpdo_cob_id(1, node), mapping, values);
}

std::optional<RpdoImage> decode_rpdo1(RpdoLayout layout, std::span<const std::uint8_t> payload) {
  const auto values = canopen::unpack_pdo(rpdo1_mapping(layout), payload);
  if (!values) return std::nullopt;
  RpdoImage image;
  image.controlword = static_cast<std::uint16_t>((*values)[0]);
  if (layout == RpdoLayout::kControlwordTarget) {
    image.target_position = static_cast<std::int32_t>(canopen::sign_extend((*values)[1], 32));
  } else {
    image.target_velocity = static_cast<std::int32_t>(canopen::sign_extend((*values)[1], 32));
    image.mode = static_cast<std::int8_t>(canopen::sign_extend((*values)[2], 8));
  }
  return image;
}

canopen::PdoMapping tpdo1_mapping() {
  return {{od::kStatusword, 0, 16}, {od::kDigitalInputs, 0, 32}, {od::kModesOfOperationDisplay, 0, 8}};
}
canopen::PdoMapping tpdo2_mapping() { return {{od::kPositionActual, 0, 32}, {od::kVelocityActual, 0, 32}}; }

std::optional<Tpdo1> decode_tpdo1(std::span<const std::uint8_t> payload) {
  const auto values = canopen::unpack_pdo(tpdo1_mapping(), payload);
  if (!values) return std::nullopt;
  return Tpdo1{static_cast<std::uint16_t>((*values)[0]), static_cast<std::uint32_t>((*values)[1]),
               static_cast<std::int8_t>(canopen::sign_extend((*values)[2], 8))};
}

std::optional<Tpdo2> decode_tpdo2(std::span<const std::uint8_t> payload) {
  const auto values = canopen::unpack_pdo(tpdo2_mapping(), payload);
  if (!values) return std::nullopt;
  return Tpdo2{static_cast<std::int32_t>(canopen::sign_extend((*values)[0], 32)),
               static_cast<std::int32_t>(canopen::sign_extend((*values)[1], 32))};
}

can::Frame encode_tpdo1(canopen::NodeId node, const Tpdo1& value) {
  const std::array<std::uint64_t, 3> values{value.statusword, value.digital_inputs, raw(value.mode_display)};
  return pdo_frame(canopen::tpdo_cob_id(1, node), tpdo1_mapping(), values);
}

can::Frame encode_tpdo2(canopen::NodeId node, const Tpdo2& value) {
  const std::array<std::uint64_t, 2> values{raw(value.position), raw(value.velocity_rpm)};
  return pdo_frame(canopen::tpdo_cob_id(2, node), tpdo2_mapping(), values);
}

std::int32_t inputs_from_60fd(std::uint32_t digital_inputs) {
  constexpr std::uint32_t kNegativeLimit = 1U << 0;
  constexpr std::uint32_t kPositiveLimit = 1U << 1;
  constexpr std::uint32_t kOrigin = 1U << 2;
  std::int32_t inputs = 0;
  if ((digital_inputs & kPositiveLimit) != 0) inputs |= 1 << 0;  // IN1
  if ((digital_inputs & kOrigin) != 0) inputs |= 1 << 1;         // IN2
  if ((digital_inputs & kNegativeLimit) != 0) inputs |= 1 << 2;  // IN3
  return inputs;
}

}  // namespace motion::uc57_driver
