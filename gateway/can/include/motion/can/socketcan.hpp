// SocketCAN transport (Linux CAN_RAW): the production path to `can0` behind a USB-CAN adapter.
//
// Threading/blocking: the can::Transport contract. One thread (the poll loop) owns the object;
// nothing blocks: the CAN socket is non-blocking, send() queues the frame in the kernel or fails
// at once (ENOBUFS when the driver's queue is full, ENETDOWN when the interface is down).
//
// fd() is an epoll descriptor that stays the same from open() to close(), also while the
// interface is down or gone: it becomes readable for frames, error frames and link changes
// (rtnetlink), so the loop needs no timer to notice the interface coming back. (It is -1 only
// while not open.) Bus events reach the on_bus_event handler from inside receive():
//   error frames (CAN_RAW_ERR_FILTER)  kErrorWarning / kErrorPassive / kBusOff / kErrorActive
//                                      (restarted), only on a state change; every error frame is
//                                      counted (Statistics::errors, SocketCanCounters).
//   interface down, removed           kDisconnected
//   interface up again                kErrorActive; a removed-and-recreated interface (adapter
//                                      replugged) is reopened on its new index, with the same
//                                      filters and own-echo setting.
// Receive timestamps are the kernel's (SO_TIMESTAMP), microseconds since the Unix epoch.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <system_error>
#include <vector>

#include "motion/can/transport.hpp"
#include "motion/can_frame/load_meter.hpp"

namespace motion::can {

struct SocketCanOptions {
  std::vector<Filter> filters;  // CAN_RAW_FILTER; empty: every frame
  bool own_echo = false;        // CAN_RAW_RECV_OWN_MSGS
  // CAN_ERR_* classes the kernel reports as error frames (CAN_RAW_ERR_FILTER); default all.
  std::uint32_t error_classes = 0x1FFFFFFFU;
  // Nominal bit rate for Statistics::bus_load; 0 (vcan, unknown) leaves bus_load at 0.
  std::uint32_t bitrate = 0;
};

// What SocketCAN tells beyond can::Statistics.
struct SocketCanCounters {
  std::uint64_t error_frames = 0;
  std::uint64_t bus_errors = 0;            // CAN_ERR_PROT / CAN_ERR_BUSERROR
  std::uint64_t ack_errors = 0;            // CAN_ERR_ACK: nobody acknowledged our frame
  std::uint64_t arbitration_lost = 0;      // CAN_ERR_LOSTARB
  std::uint64_t tx_timeouts = 0;           // CAN_ERR_TX_TIMEOUT
  std::uint64_t controller_overflows = 0;  // CAN_ERR_CRTL rx/tx buffer overflow
  std::uint64_t transceiver_errors = 0;    // CAN_ERR_TRX
  std::uint64_t restarts = 0;              // CAN_ERR_RESTARTED
  std::uint64_t socket_drops = 0;          // frames the kernel dropped for this socket (SO_RXQ_OVFL)
  std::uint64_t tx_queue_full = 0;         // send() refused with ENOBUFS/EAGAIN
  std::uint64_t link_down = 0;             // interface went down or away
  std::uint64_t reopens = 0;               // socket reopened after the interface came back
};

class SocketCanTransport final : public Transport {
 public:
  SocketCanTransport() = default;
  ~SocketCanTransport() override;
  SocketCanTransport(const SocketCanTransport&) = delete;
  SocketCanTransport& operator=(const SocketCanTransport&) = delete;

  // Opens `interface` ("can0", "vcan0"); closes the previous one first. Errors name the
  // interface (socketcan_error.hpp): no_such_device (missing, or not a CAN interface),
  // address_family_not_supported / protocol_not_supported (kernel without AF_CAN).
  // An existing but down interface is not an error: it opens in state kDisconnected and
  // recovers when it comes up.
  std::error_code open(std::string_view interface, SocketCanOptions options = {});
  void close();
  [[nodiscard]] bool is_open() const { return epoll_fd_ >= 0; }

  [[nodiscard]] std::string name() const override { return interface_; }
  [[nodiscard]] int fd() const override { return epoll_fd_; }
  std::error_code send(const Frame& frame) override;
  // One sendmmsg() for the frames the kernel takes at once (a refusal: send()'s error for it).
  std::size_t send_batch(std::span<const Frame> frames, std::error_code& error) override;
  std::optional<Frame> receive() override;
  std::error_code set_filters(const std::vector<Filter>& filters) override;
  std::error_code set_own_echo(bool enabled) override;
  [[nodiscard]] BusState state() const override { return state_; }
  [[nodiscard]] Statistics statistics() const override;
  [[nodiscard]] const SocketCanCounters& counters() const { return counters_; }

 private:
  enum class ReadResult : std::uint8_t { kFrame, kHandled, kEmpty };
  ReadResult read_one(Frame& out);
  void handle_error_frame(std::uint32_t can_id, const std::uint8_t* data);
  void handle_socket_error(int error);
  // Re-reads the interface's index and flags after a link notification or socket error and
  // moves state_ accordingly; reopens the CAN socket when the interface was recreated.
  void refresh_link();
  // Drains rtnetlink; true when the CAN socket was reopened (it may hold frames now).
  bool drain_link_events();
  std::error_code open_can_socket();
  // rtnetlink socket and the epoll set behind fd().
  std::error_code open_link_watch();
  std::error_code watch(int fd);  // adds to the epoll set behind fd()
  std::error_code apply_socket_options();
  void close_can_socket();
  void enter_state(BusState next, std::uint32_t error_class, const std::string& text);

  std::string interface_;
  SocketCanOptions options_;
  int epoll_fd_ = -1;
  int can_fd_ = -1;   // -1 while the interface is gone
  int link_fd_ = -1;  // rtnetlink, RTMGRP_LINK
  int ifindex_ = 0;
  BusState state_ = BusState::kDisconnected;
  bool carrier_lost_in_bus_off_ = false;
  std::uint32_t last_socket_drops_ = 0;
  Statistics stats_;
  SocketCanCounters counters_;
  LoadMeter load_;  // bus_load, from the frames sent and received (options_.bitrate)
};

}  // namespace motion::can
