// CANopen frames as the UC57 gateway's master receives them (CiA 301: SDO, EMCY, NMT error
// control/heartbeat, SYNC, PDOs to the unhandled-frame path): the pure decoders on every payload,
// and the stateful Master (SDO client in the middle of an upload and a segmented download, NMT
// master, EMCY consumer) fed the same frames. Input: frames as u16 COB-ID (11 bits), a length
// byte, the payload; time advances 1 ms per frame.
#include "fuzz_targets.hpp"
#include "motion/can_frame/frame.hpp"
#include "motion/canopen/emcy.hpp"
#include "motion/canopen/master.hpp"
#include "motion/canopen/nmt.hpp"
#include "motion/canopen/sdo.hpp"
#include "motion/canopen/sync.hpp"

namespace motion::fuzz {

int canopen(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  canopen::Master master([](const can::Frame&) {});
  master.sdo().upload(5, {0x1008, 0}, [](std::error_code, std::span<const std::uint8_t>) {});
  master.sdo().download(
      6, {0x2000, 1}, std::vector<std::uint8_t>(20, 0x5A), [](std::error_code, std::span<const std::uint8_t>) {},
      canopen::SdoDownloadMode::kSegmented);
  TimePoint now{};
  while (!in.empty()) {
    const std::uint16_t cob_id = in.u16() & 0x7FFU;
    const auto payload = in.take(in.byte() % 9U);
    (void)canopen::decode_sdo_request(payload);
    (void)canopen::decode_sdo_response(payload);
    (void)canopen::decode_emcy(payload);
    (void)canopen::decode_nmt(payload);
    (void)canopen::decode_heartbeat(payload);
    (void)canopen::decode_sync(payload);
    const auto frame = can::Frame::make(cob_id, false, payload);
    if (!frame) continue;
    now += std::chrono::milliseconds(1);
    master.on_frame(*frame, now);
    (void)master.sdo().process(now);
  }
  return 0;
}

}  // namespace motion::fuzz
