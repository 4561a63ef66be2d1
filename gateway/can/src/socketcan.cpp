#include "motion/can/socketcan.hpp"

#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <linux/netlink.h>
#include <linux/rtnetlink.h>
#include <net/if.h>
#include <sys/epoll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>

#include <cerrno>
#include <cstring>
#include <utility>

#include "motion/can/batched_send.hpp"
#include "motion/can/socketcan_error.hpp"
#include "socketcan_detail.hpp"

namespace motion::can {
namespace {

constexpr std::int64_t kMicrosPerSecond = 1'000'000;

std::int64_t clock_us(clockid_t clock) {
  timespec ts{};
  ::clock_gettime(clock, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * kMicrosPerSecond + ts.tv_nsec / 1000;
}

std::string describe_error_frame(std::uint32_t error_class, std::uint8_t controller) {
  std::string text;
  const auto add = [&text](const char* part) {
    if (!text.empty()) text += ", ";
    text += part;
  };
  if (error_class & CAN_ERR_BUSOFF) add("bus-off");
  if (error_class & CAN_ERR_RESTARTED) add("controller restarted");
  if (error_class & CAN_ERR_CRTL) {
    if (controller & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) add("error-passive");
    if (controller & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) add("error-warning");
    if (controller & CAN_ERR_CRTL_ACTIVE) add("back to error-active");
    if (controller & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) add("controller buffer overflow");
  }
  if (error_class & CAN_ERR_TX_TIMEOUT) add("tx timeout");
  if (error_class & CAN_ERR_LOSTARB) add("arbitration lost");
  if (error_class & (CAN_ERR_PROT | CAN_ERR_BUSERROR)) add("bus error");
  if (error_class & CAN_ERR_ACK) add("no ACK");
  if (error_class & CAN_ERR_TRX) add("transceiver error");
  return text.empty() ? "error frame" : text;
}

// The fault-confinement state an error frame announces, if any.
std::optional<BusState> announced_state(std::uint32_t error_class, std::uint8_t controller) {
  if (error_class & CAN_ERR_BUSOFF) return BusState::kBusOff;
  if (error_class & CAN_ERR_RESTARTED) return BusState::kErrorActive;
  if (error_class & CAN_ERR_CRTL) {
    if (controller & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) return BusState::kErrorPassive;
    if (controller & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) return BusState::kErrorWarning;
    if (controller & CAN_ERR_CRTL_ACTIVE) return BusState::kErrorActive;
  }
  return std::nullopt;
}

struct LinkStatus {
  int index = 0;  // 0: no such interface
  bool up = false;
  bool running = false;  // carrier: a CAN controller drops it in bus-off
};

LinkStatus query_link(const std::string& interface, int ioctl_fd) {
  LinkStatus link;
  int index = 0;
  if (detail::interface_index(interface, index)) return link;
  link.index = index;
  ifreq request{};
  std::strncpy(request.ifr_name, interface.c_str(), IFNAMSIZ - 1);
  if (::ioctl(ioctl_fd, SIOCGIFFLAGS, &request) != 0) return link;
  const auto flags = static_cast<unsigned>(request.ifr_flags);
  link.up = (flags & IFF_UP) != 0;
  link.running = (flags & IFF_RUNNING) != 0;
  return link;
}

std::error_code set_option(const std::string& interface, int fd, int level, int name, const void* value,
                           std::size_t size) {
  if (::setsockopt(fd, level, name, value, static_cast<socklen_t>(size)) != 0) return detail::last_error(interface);
  return {};
}

std::error_code set_flag(const std::string& interface, int fd, int level, int name, bool enabled) {
  const int value = enabled ? 1 : 0;
  return set_option(interface, fd, level, name, &value, sizeof value);
}

std::vector<can_filter> kernel_filters(const std::vector<Filter>& filters) {
  if (filters.empty()) return {can_filter{0, 0}};  // the kernel reads "no filter" as "nothing"
  std::vector<can_filter> out;
  out.reserve(filters.size());
  for (const auto& f : filters) {
    can_filter k{f.id & CAN_EFF_MASK, f.mask & CAN_EFF_MASK};
    if (f.match_format) {
      k.can_mask |= CAN_EFF_FLAG;
      if (f.extended) k.can_id |= CAN_EFF_FLAG;
    }
    out.push_back(k);
  }
  return out;
}

}  // namespace

SocketCanTransport::~SocketCanTransport() { close(); }

void SocketCanTransport::close() {
  close_can_socket();
  for (int* fd : {&link_fd_, &epoll_fd_}) detail::UniqueFd(std::exchange(*fd, -1)).reset();
  state_ = BusState::kDisconnected;
}

std::error_code SocketCanTransport::open(std::string_view interface, SocketCanOptions options) {
  close();
  interface_ = std::string(interface);
  options_ = std::move(options);
  stats_ = {};
  counters_ = {};
  if (auto ec = open_can_socket()) return ec;
  if (auto ec = open_link_watch()) {
    close();
    return ec;
  }
  const LinkStatus status = query_link(interface_, link_fd_);
  state_ = status.up && status.running ? BusState::kErrorActive : BusState::kDisconnected;
  load_ = LoadMeter(options_.bitrate);
  return {};
}

// On failure the caller closes whatever was opened.
std::error_code SocketCanTransport::open_link_watch() {
  link_fd_ = ::socket(AF_NETLINK, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, NETLINK_ROUTE);
  if (link_fd_ < 0) return detail::last_error(interface_);
  sockaddr_nl groups{};
  groups.nl_family = AF_NETLINK;
  groups.nl_groups = RTMGRP_LINK;
  if (::bind(link_fd_, reinterpret_cast<sockaddr*>(&groups), sizeof groups) != 0) return detail::last_error(interface_);
  epoll_fd_ = ::epoll_create1(EPOLL_CLOEXEC);
  if (epoll_fd_ < 0) return detail::last_error(interface_);
  if (auto ec = watch(link_fd_)) return ec;
  return watch(can_fd_);
}

std::error_code SocketCanTransport::watch(int fd) {
  epoll_event readable{};
  readable.events = EPOLLIN;
  readable.data.fd = fd;
  if (::epoll_ctl(epoll_fd_, EPOLL_CTL_ADD, fd, &readable) != 0) return detail::last_error(interface_);
  return {};
}

std::error_code SocketCanTransport::open_can_socket() {
  detail::UniqueFd fd;
  int index = 0;
  if (auto ec = detail::open_can_socket(interface_, CAN_RAW, fd, index)) return ec;
  can_fd_ = fd.release();
  ifindex_ = index;
  std::error_code ec = apply_socket_options();
  if (!ec && epoll_fd_ >= 0) ec = watch(can_fd_);  // at open() the epoll set comes later
  if (ec) close_can_socket();
  return ec;
}

std::error_code SocketCanTransport::apply_socket_options() {
  const auto filters = kernel_filters(options_.filters);
  if (auto ec = set_option(interface_, can_fd_, SOL_CAN_RAW, CAN_RAW_FILTER, filters.data(),
                           filters.size() * sizeof(can_filter))) {
    return ec;
  }
  const can_err_mask_t error_mask = options_.error_classes & CAN_ERR_MASK;
  if (auto ec = set_option(interface_, can_fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &error_mask, sizeof error_mask))
    return ec;
  if (auto ec = set_flag(interface_, can_fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, options_.own_echo)) return ec;
  if (auto ec = set_flag(interface_, can_fd_, SOL_SOCKET, SO_TIMESTAMP, true)) return ec;
  return set_flag(interface_, can_fd_, SOL_SOCKET, SO_RXQ_OVFL, true);
}

void SocketCanTransport::close_can_socket() {
  if (can_fd_ < 0) return;
  // Closing removes it from the epoll set too (no other descriptor refers to the socket).
  detail::UniqueFd(std::exchange(can_fd_, -1)).reset();
  last_socket_drops_ = 0;
}

std::error_code SocketCanTransport::send(const Frame& frame) {
  const auto refuse = [this](int error) {
    ++stats_.tx_dropped;
    return socketcan_error(interface_, error);
  };
  if (!is_open()) return refuse(EBADF);
  can_frame raw{};
  if (!detail::to_kernel_frame(frame, raw)) return refuse(EINVAL);
  if (can_fd_ < 0) return refuse(ENODEV);
  const auto write_frame = [this, &raw]() -> int {  // 0 or errno
    for (;;) {
      if (::send(can_fd_, &raw, sizeof raw, MSG_DONTWAIT) >= 0) return 0;
      if (errno != EINTR) return errno;
    }
  };
  int error = write_frame();
  // A down/up the loop has not read yet leaves ENETDOWN pending on the socket, and this send
  // consumed it: retry once when the interface is in fact up again.
  if (error == ENETDOWN) {
    const LinkStatus link = query_link(interface_, link_fd_);
    if (link.up && link.running) error = write_frame();
  }
  if (error != 0) {
    // State changes (down, removed) arrive through the socket error and rtnetlink in receive().
    if (error == ENOBUFS || error == EAGAIN) ++counters_.tx_queue_full;
    return refuse(error);
  }
  ++stats_.tx_frames;
  stats_.tx_bytes += frame.rtr ? 0U : frame.dlc;
  load_.add(frame, SteadyClock::now());
  return {};
}

std::size_t SocketCanTransport::send_batch(std::span<const Frame> frames, std::error_code& error) {
  BatchedSend how;
  how.fd = is_open() ? can_fd_ : -1;
  how.encode = [](const Frame& frame, std::span<std::uint8_t, kMaxBatchedMessage> out) -> std::size_t {
    can_frame raw{};
    if (!detail::to_kernel_frame(frame, raw)) return 0;
    std::memcpy(out.data(), &raw, sizeof raw);
    return sizeof raw;
  };
  how.single = [this](const Frame& frame) { return send(frame); };
  how.taken = [this](const Frame& frame) {
    ++stats_.tx_frames;
    stats_.tx_bytes += frame.rtr ? 0U : frame.dlc;
    load_.add(frame, SteadyClock::now());
  };
  return send_batched(how, frames, error);
}

std::optional<Frame> SocketCanTransport::receive() {
  if (!is_open()) return std::nullopt;
  for (;;) {
    Frame frame;
    switch (read_one(frame)) {
      case ReadResult::kFrame: return frame;
      case ReadResult::kHandled: continue;
      case ReadResult::kEmpty: break;
    }
    // Link notifications are looked at once the CAN socket is drained: one extra syscall per
    // wake-up, not per frame.
    if (!drain_link_events()) return std::nullopt;
  }
}

SocketCanTransport::ReadResult SocketCanTransport::read_one(Frame& out) {
  if (can_fd_ < 0) return ReadResult::kEmpty;
  can_frame raw{};
  iovec data{&raw, sizeof raw};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))];
  msghdr message{};
  message.msg_iov = &data;
  message.msg_iovlen = 1;
  message.msg_control = control;
  message.msg_controllen = sizeof control;
  ssize_t size = 0;
  do { size = ::recvmsg(can_fd_, &message, MSG_DONTWAIT); } while (size < 0 && errno == EINTR);
  if (size < 0) {
    if (errno == EAGAIN || errno == EWOULDBLOCK) return ReadResult::kEmpty;
    handle_socket_error(errno);
    return can_fd_ >= 0 ? ReadResult::kHandled : ReadResult::kEmpty;
  }
  if (static_cast<std::size_t>(size) != sizeof raw) {  // CAN FD is not enabled; be safe anyway
    ++stats_.errors;
    return ReadResult::kHandled;
  }

  std::int64_t timestamp_us = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&message); c != nullptr; c = CMSG_NXTHDR(&message, c)) {
    if (c->cmsg_level != SOL_SOCKET) continue;
    if (c->cmsg_type == SCM_TIMESTAMP) {
      timeval tv{};
      std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
      timestamp_us = static_cast<std::int64_t>(tv.tv_sec) * kMicrosPerSecond + tv.tv_usec;
    } else if (c->cmsg_type == SO_RXQ_OVFL) {
      std::uint32_t drops = 0;  // the socket's running total
      std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
      counters_.socket_drops += drops - last_socket_drops_;
      last_socket_drops_ = drops;
    }
  }

  if (raw.can_id & CAN_ERR_FLAG) {
    handle_error_frame(raw.can_id & CAN_ERR_MASK, raw.data);
    return ReadResult::kHandled;
  }
  out = detail::from_kernel_frame(raw);
  out.timestamp_us = timestamp_us != 0 ? timestamp_us : clock_us(CLOCK_REALTIME);
  ++stats_.rx_frames;
  stats_.rx_bytes += out.rtr ? 0U : out.dlc;
  load_.add(out, SteadyClock::now());
  return ReadResult::kFrame;
}

void SocketCanTransport::handle_error_frame(std::uint32_t error_class, const std::uint8_t* data) {
  ++stats_.errors;
  ++counters_.error_frames;
  const std::uint8_t controller = data[1];
  if (error_class & (CAN_ERR_PROT | CAN_ERR_BUSERROR)) ++counters_.bus_errors;
  if (error_class & CAN_ERR_ACK) ++counters_.ack_errors;
  if (error_class & CAN_ERR_LOSTARB) ++counters_.arbitration_lost;
  if (error_class & CAN_ERR_TX_TIMEOUT) ++counters_.tx_timeouts;
  if (error_class & CAN_ERR_TRX) ++counters_.transceiver_errors;
  if (error_class & CAN_ERR_RESTARTED) ++counters_.restarts;
  if ((error_class & CAN_ERR_CRTL) && (controller & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW))) {
    ++counters_.controller_overflows;
  }
  if (const auto next = announced_state(error_class, controller)) {
    enter_state(*next, error_class, describe_error_frame(error_class, controller));
  }
}

void SocketCanTransport::handle_socket_error(int error) {
  switch (error) {
    case ENETDOWN:  // interface set down; the socket stays bound and works again once it is up
      enter_state(BusState::kDisconnected, 0, "interface down");
      break;
    case ENODEV:  // interface unregistered (adapter unplugged): the socket is unbound for good
      close_can_socket();
      enter_state(BusState::kDisconnected, 0, "interface removed");
      break;
    default: ++stats_.errors; return;
  }
  // The interface may already be back (the loop woke late): report the recovery right away.
  refresh_link();
}

bool SocketCanTransport::drain_link_events() {
  bool notified = false;
  char buffer[8192];
  for (;;) {
    const ssize_t size = ::recv(link_fd_, buffer, sizeof buffer, MSG_DONTWAIT);
    if (size > 0 || (size < 0 && (errno == EINTR || errno == ENOBUFS))) {  // ENOBUFS: missed some
      notified = true;
      continue;
    }
    break;
  }
  if (!notified) return false;
  const auto reopens_before = counters_.reopens;
  refresh_link();
  return counters_.reopens != reopens_before;
}

void SocketCanTransport::refresh_link() {
  const LinkStatus link = query_link(interface_, link_fd_);
  if (link.index == 0) {
    close_can_socket();
    enter_state(BusState::kDisconnected, 0, "interface removed");
    return;
  }
  if (link.index != ifindex_) close_can_socket();  // recreated: the old socket is unbound
  if (!link.up) {
    enter_state(BusState::kDisconnected, 0, "interface down");
    return;
  }
  if (!link.running) {
    if (state_ == BusState::kBusOff) {
      carrier_lost_in_bus_off_ = true;  // the controller is restarting
    } else {
      enter_state(BusState::kDisconnected, 0, "no carrier");
    }
    return;
  }
  if (can_fd_ < 0) {
    if (auto ec = open_can_socket()) {
      enter_state(BusState::kDisconnected, 0, "reopen failed: " + ec.message());
      return;
    }
    ++counters_.reopens;
  }
  if (state_ == BusState::kDisconnected || (state_ == BusState::kBusOff && carrier_lost_in_bus_off_)) {
    enter_state(BusState::kErrorActive, CAN_ERR_RESTARTED, "interface up again");
  }
}

void SocketCanTransport::enter_state(BusState next, std::uint32_t error_class, const std::string& text) {
  if (next == state_) return;
  if (next == BusState::kDisconnected) ++counters_.link_down;
  if (next == BusState::kBusOff) ++stats_.bus_off_count;
  carrier_lost_in_bus_off_ = false;
  state_ = next;
  emit_bus_event(BusEvent{next, error_class, interface_ + ": " + text});
}

std::error_code SocketCanTransport::set_filters(const std::vector<Filter>& filters) {
  options_.filters = filters;
  if (can_fd_ < 0) return {};  // applied when the socket is (re)opened
  const auto kernel = kernel_filters(filters);
  return set_option(interface_, can_fd_, SOL_CAN_RAW, CAN_RAW_FILTER, kernel.data(),
                    kernel.size() * sizeof(can_filter));
}

std::error_code SocketCanTransport::set_own_echo(bool enabled) {
  options_.own_echo = enabled;
  if (can_fd_ < 0) return {};
  return set_flag(interface_, can_fd_, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, enabled);
}

Statistics SocketCanTransport::statistics() const {
  Statistics out = stats_;
  out.bus_load = load_.load(SteadyClock::now());
  return out;
}

}  // namespace motion::can
