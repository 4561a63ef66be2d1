// The UC57 process data as the gateway decodes it (UC57 manual §5 communication table: TPDO1 =
// 6041h + 60FDh + 6061h, TPDO2 = 6064h + 606Ch; RPDO1 in both layouts, see process_data.hpp) on
// every payload, and the input numbering of 60FDh. What decodes must encode to a frame that
// decodes to the same value (a decoder that reads past its mapping or a lossy encoder is a
// finding). Input: frames as u16 COB-ID (11 bits), a length byte, the payload (the canopen
// target's format, so its seeds apply).
#include <cstdlib>

#include "fuzz_targets.hpp"
#include "motion/uc57_driver/process_data.hpp"

namespace motion::fuzz {

int uc57_pdo(const std::uint8_t* data, std::size_t size) {
  using namespace motion::uc57_driver;
  Input in(data, size);
  while (!in.empty()) {
    const auto node = static_cast<canopen::NodeId>(1 + (in.u16() & 0x7FU) % 127U);
    const auto payload = in.take(in.byte() % 9U);
    if (const auto t1 = decode_tpdo1(payload)) {
      (void)inputs_from_60fd(t1->digital_inputs);
      const auto frame = encode_tpdo1(node, *t1);
      const auto again = decode_tpdo1(frame.payload());
      if (!again || again->statusword != t1->statusword || again->digital_inputs != t1->digital_inputs ||
          again->mode_display != t1->mode_display)
        std::abort();
    }
    if (const auto t2 = decode_tpdo2(payload)) {
      const auto again = decode_tpdo2(encode_tpdo2(node, *t2).payload());
      if (!again || again->position != t2->position || again->velocity_rpm != t2->velocity_rpm) std::abort();
    }
    for (const auto layout : {RpdoLayout::kControlwordTarget, RpdoLayout::kManualDefault}) {
      if (const auto image = decode_rpdo1(layout, payload)) {
        const auto again = decode_rpdo1(layout, encode_rpdo1(node, layout, *image).payload());
        if (!again || !(*again == *image)) std::abort();
      }
    }
  }
  return 0;
}

}  // namespace motion::fuzz
