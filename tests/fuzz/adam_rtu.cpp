// ADAM Modbus RTU (ADAM manual, Modbus RTU framing; Modbus over serial line v1.02 §2.5): the
// master's response decoding, context-free and matched against a request (normal replies and
// exception replies), the slave's (simulator's) request decoding, and the line's silence framer
// fed in pieces. First bytes: the request the response answers.
#include "fuzz_targets.hpp"
#include "motion/adam/rtu.hpp"
#include "motion/serial/silence_framer.hpp"

namespace motion::fuzz {

int adam_rtu(const std::uint8_t* data, std::size_t size) {
  Input in(data, size);
  adam::rtu::Request request;
  request.unit = in.byte();
  const std::uint8_t kind = in.byte();
  const std::uint16_t start = in.u16();
  const std::uint16_t quantity = in.u16();
  switch (kind % 3U) {
    case 0: request.pdu = adam::rtu::ReadRegisters{start, quantity}; break;
    case 1: request.pdu = adam::rtu::WriteRegister{start, quantity}; break;
    default: request.pdu = adam::rtu::WriteRegisters{start, std::vector<std::uint16_t>(quantity % 130U, 0x1234)}; break;
  }
  const auto frame = in.rest();
  (void)adam::rtu::decode_response(frame);
  (void)adam::rtu::decode_response(frame, request);
  (void)adam::rtu::decode_request(frame);

  serial::SilenceFramer framer(std::chrono::microseconds(1750));
  TimePoint now{};
  for (std::size_t at = 0; at < frame.size(); at += 3) {
    framer.push(frame.subspan(at, std::min<std::size_t>(3, frame.size() - at)), now);
    now += std::chrono::microseconds(frame[at] * 10);  // gaps from the data: some close frames
    if (auto taken = framer.take_if_silent(now)) (void)adam::rtu::decode_response(*taken, request);
  }
  (void)adam::rtu::decode_response(framer.complete_now(), request);
  return 0;
}

}  // namespace motion::fuzz
