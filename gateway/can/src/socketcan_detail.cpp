#include "socketcan_detail.hpp"

#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "motion/can/socketcan_error.hpp"

namespace motion::can::detail {

canid_t kernel_id(std::uint32_t id, bool extended) {
  return extended ? ((id & CAN_EFF_MASK) | CAN_EFF_FLAG) : (id & CAN_SFF_MASK);
}

bool to_kernel_frame(const Frame& frame, can_frame& out) {
  if (frame.dlc > CAN_MAX_DLEN) return false;
  if (frame.id > (frame.extended ? kMaxExtendedId : kMaxStandardId)) return false;
  out = can_frame{};
  out.can_id = kernel_id(frame.id, frame.extended) | (frame.rtr ? CAN_RTR_FLAG : 0U);
  out.len = frame.dlc;
  if (!frame.rtr) std::memcpy(out.data, frame.data.data(), frame.dlc);
  return true;
}

Frame from_kernel_frame(const can_frame& in) {
  Frame frame;
  frame.extended = (in.can_id & CAN_EFF_FLAG) != 0;
  frame.rtr = (in.can_id & CAN_RTR_FLAG) != 0;
  frame.id = in.can_id & (frame.extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  frame.dlc = in.len > CAN_MAX_DLEN ? std::uint8_t{CAN_MAX_DLEN} : in.len;
  if (!frame.rtr) std::memcpy(frame.data.data(), in.data, frame.dlc);
  return frame;
}

void UniqueFd::reset(int fd) {
  if (fd_ >= 0) ::close(fd_);
  fd_ = fd;
}

std::error_code last_error(std::string_view interface) { return socketcan_error(interface, errno); }

std::error_code interface_index(std::string_view interface, int& index) {
  if (interface.empty()) return socketcan_error(interface, ENODEV);
  if (interface.size() >= IFNAMSIZ) return socketcan_error(interface, ENAMETOOLONG);
  const std::string name(interface);
  const unsigned found = ::if_nametoindex(name.c_str());
  if (found == 0) return socketcan_error(interface, ENODEV);
  index = static_cast<int>(found);
  return {};
}

std::error_code open_can_socket(std::string_view interface, int protocol, UniqueFd& out, int& ifindex) {
  const int type = protocol == CAN_BCM ? SOCK_DGRAM : SOCK_RAW;
  // Create the socket first: without AF_CAN that is the error worth reporting, whatever the name.
  UniqueFd fd(::socket(PF_CAN, type | SOCK_NONBLOCK | SOCK_CLOEXEC, protocol));
  if (!fd.valid()) return last_error(interface);
  int index = 0;
  if (auto ec = interface_index(interface, index)) return ec;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = index;
  auto* sa = reinterpret_cast<sockaddr*>(&addr);
  const int rc = protocol == CAN_BCM ? ::connect(fd.get(), sa, sizeof addr) : ::bind(fd.get(), sa, sizeof addr);
  if (rc != 0) return last_error(interface);
  out = std::move(fd);
  ifindex = index;
  return {};
}

}  // namespace motion::can::detail
