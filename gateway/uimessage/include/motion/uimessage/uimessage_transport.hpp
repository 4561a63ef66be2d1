// A can::Transport through a UIROBOT serial gateway, UIM2513 (RS232-CAN) or UIM2533 (USB-CAN):
// the gateway exchanges SimpleCAN 3.0 messages with the host as 16-byte UIMessages (UIM342 manual
// §2.6 and Appendix-1) and puts them on its CAN bus itself, so the UIM342
// stack runs over it unchanged.
//   send(frame)  a 29-bit SimpleCAN frame from the host (producer 4) becomes a UIMessage whose ID
//                is the frame's consumer, written to the port. Nothing else can travel (the
//                message has no producer field and no 11-bit form): 11-bit frames (CANopen), RTR
//                frames, identifiers with reserved bits set and other producers fail at once
//                with a UiMessageErrc.
//   receive()    bytes from the port go through uim342::UiMessageStream (resynchronizes on
//                SM..EM, checks the CRC) and come out as the drive's frame: producer = the
//                UIMessage ID, consumer = the host.
// The CRC coverage sent is configured (the manual's SM..d8 or ID..d8) or detected from the
// gateway's frames (CrcDetector, crc_detector.hpp: the default of a uimessage: bus); receive
// accepts either unless told to be strict. A detected coverage is told once through
// on_crc_detected (the gateway makes it an INFO CONFIG_MISMATCH event) and again if it changes. Garbage and corrupt frames are dropped and counted, never
// delivered.
//
// Threading/blocking: the can::Transport contract. One thread (the poll loop) owns the object;
// nothing blocks: the port is non-blocking, send() hands the 16 bytes to the tty buffer or fails
// at once (EAGAIN when the buffer is full).
//
// fd() is an epoll descriptor that stays the same from open() to destruction: readable for bytes
// on the port and for own-echo frames. When the port hangs up or fails (USB adapter unplugged),
// receive() closes it and reports kDisconnected through on_bus_event; the first send() at least
// `reopen_interval` later opens the device again (the stacks keep polling, so a replugged adapter
// comes back, kErrorActive, without a timer here).
//
// Own echo: the gateway confirms nothing, so an echoed frame means "written to the port".
// Statistics: frames and payload bytes as CAN frames; errors = CRC errors, malformed UIMessages
// and messages that make no SimpleCAN frame; bus_load is not measured (the CAN side is the
// gateway's).
#pragma once

#include <chrono>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <system_error>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/config/config.hpp"
#include "motion/serial/serial_port.hpp"
#include "motion/uim342/identifier.hpp"
#include "motion/uim342/uimessage.hpp"
#include "motion/uim342/uimessage_stream.hpp"
#include "motion/uimessage/crc_detector.hpp"

namespace motion::uimessage {

// Why send() refused a frame (besides errno-style I/O errors of the port).
enum class UiMessageErrc {
  kStandardFrame = 1,  // 11-bit identifier
  kRemoteFrame,        // RTR
  kNotSimpleCan,       // 29-bit identifier that is not SimpleCAN 3.0 (reserved bits set)
  kForeignProducer,    // producer is not the host ID
  kDisconnected,       // the port hung up and could not be opened again (yet)
};
[[nodiscard]] const std::error_category& uimessage_category();  // name() == "uimessage"
[[nodiscard]] std::error_code make_error_code(UiMessageErrc error);

struct UiMessageOptions {
  uim342::CrcCoverage crc = uim342::CrcCoverage::kStartToAux;     // what send() writes (first)
  bool detect_crc = false;                                        // follow the gateway's coverage
  uim342::CrcAcceptance accept = uim342::CrcAcceptance::kEither;  // what receive() takes
  std::uint8_t host_id = uim342::kMasterId;                       // the master the gateway stands for
  std::chrono::milliseconds reopen_interval{1000};                // between attempts after a hang-up
};

// The options a bus's configuration asks for (uimessage_crc: detect | 13 | 12, uimessage_crc_strict).
[[nodiscard]] UiMessageOptions options_from(const config::Bus& bus);

// What the transport saw beyond can::Statistics.
struct UiMessageCounters {
  uim342::UiMessageStream::Counters stream;  // frames, CRC errors, malformed, discarded bytes
  std::uint64_t crc_start_to_aux = 0;        // received frames whose CRC covers SM..d8
  std::uint64_t crc_id_to_aux = 0;           // ... ID..d8 (not both: the first that matches counts)
  std::uint64_t crc_blind_switches = 0;      // send-side switches while nothing had answered (detect)
  std::uint64_t without_crc = 0;             // SM = 0xAD
  std::uint64_t unconvertible = 0;           // well-formed UIMessages with an ID above 127
  std::uint64_t disconnects = 0;
  std::uint64_t reopens = 0;
};

class UiMessageTransport final : public can::Transport {
 public:
  // Opens `device` (e.g. /dev/ttyUSB0) with `settings`. nullptr with `error` set: the port's
  // errno (ENOENT no such device, EACCES no permission, ENOTTY not a serial port, EINVAL a baud
  // rate termios lacks) or the epoll/eventfd failure.
  static std::unique_ptr<UiMessageTransport> open(std::string device, const serial::SerialSettings& settings,
                                                  UiMessageOptions options, std::error_code& error);
  ~UiMessageTransport() override;
  UiMessageTransport(const UiMessageTransport&) = delete;
  UiMessageTransport& operator=(const UiMessageTransport&) = delete;

  [[nodiscard]] std::string name() const override { return "uimessage:" + device_; }
  [[nodiscard]] int fd() const override { return epoll_fd_; }
  std::error_code send(const can::Frame& frame) override;
  std::optional<can::Frame> receive() override;
  std::error_code set_filters(const std::vector<can::Filter>& filters) override;
  std::error_code set_own_echo(bool enabled) override;
  [[nodiscard]] can::BusState state() const override { return state_; }
  [[nodiscard]] can::Statistics statistics() const override;
  [[nodiscard]] UiMessageCounters counters() const;
  // The CRC coverage send() writes now, and how it was chosen (CrcDetector::describe()).
  [[nodiscard]] uim342::CrcCoverage crc_sending() const { return crc_.sending(); }
  [[nodiscard]] std::string crc_status() const { return crc_.describe(); }
  // Called from receive() when detection decides or changes the coverage sent; `text` says which.
  void on_crc_detected(std::function<void(const std::string& text)> handler) { crc_handler_ = std::move(handler); }

 private:
  UiMessageTransport(std::string device, const serial::SerialSettings& settings, UiMessageOptions options);
  std::error_code open_port();
  void close_port(const std::string& why);
  bool try_reopen();  // true when the port is open again
  [[nodiscard]] bool port_hung_up() const;
  void enter_state(can::BusState next, std::string text);
  // A received message as the drive's CAN frame; nullopt (counted) when it makes none.
  std::optional<can::Frame> to_frame(const uim342::DecodedUiMessage& decoded);
  std::optional<can::Frame> next_echo();

  std::string device_;
  serial::SerialSettings settings_;
  UiMessageOptions options_;
  int epoll_fd_ = -1;
  int echo_fd_ = -1;  // eventfd: own-echo frames waiting
  std::unique_ptr<serial::SerialPort> port_;
  uim342::UiMessageStream stream_;
  CrcDetector crc_;
  std::function<void(const std::string&)> crc_handler_;
  can::BusState state_ = can::BusState::kDisconnected;
  std::chrono::steady_clock::time_point last_open_attempt_{};
  std::vector<can::Filter> filters_;
  bool own_echo_ = false;
  std::deque<can::Frame> echoes_;
  can::Statistics stats_;
  UiMessageCounters counters_;
};

}  // namespace motion::uimessage

template <>
struct std::is_error_code_enum<motion::uimessage::UiMessageErrc> : std::true_type {};
