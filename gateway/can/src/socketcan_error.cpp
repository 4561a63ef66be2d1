#include "motion/can/socketcan_error.hpp"

#include <cerrno>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace motion::can {
namespace {

class InterfaceErrorCategory final : public std::error_category {
 public:
  explicit InterfaceErrorCategory(std::string interface) : interface_(std::move(interface)) {}

  [[nodiscard]] const char* name() const noexcept override { return "socketcan"; }

  [[nodiscard]] std::string message(int ev) const override {
    const std::string what = "SocketCAN interface '" + interface_ + "'";
    switch (ev) {
      case ENODEV: return what + " does not exist or is not a CAN interface (ip -details link show " + interface_ + ")";
      case EAFNOSUPPORT:
      case EPROTONOSUPPORT:
        return "cannot open " + what + ": this kernel has no AF_CAN support (modules can, can-raw, can-bcm)";
      case ENETDOWN: return what + " is down (ip link set " + interface_ + " up)";
      case ENOBUFS:
      case EAGAIN: return what + ": transmit queue full (no ACK on the bus, bus-off, or txqueuelen too small)";
      case EBADF:
      case ENOTCONN: return what + " is not open";
      case ENAMETOOLONG: return what + ": name longer than 15 characters";
      case EINVAL: return what + ": invalid frame or argument";
      case ENOENT: return what + ": no cyclic transmission with that identifier";
      default: return what + ": " + std::generic_category().message(ev);
    }
  }

  // Compare equal to std::errc the way a generic_category code would.
  [[nodiscard]] std::error_condition default_error_condition(int ev) const noexcept override {
    return std::generic_category().default_error_condition(ev);
  }

 private:
  std::string interface_;
};

const std::error_category& category_for(std::string_view interface) {
  static std::mutex mutex;
  // Deliberately never freed: error codes may outlive every transport (and static destruction).
  static auto* categories = new std::map<std::string, std::unique_ptr<InterfaceErrorCategory>, std::less<>>;
  const std::lock_guard lock(mutex);
  auto it = categories->find(interface);
  if (it == categories->end()) {
    it = categories->emplace(std::string(interface), std::make_unique<InterfaceErrorCategory>(std::string(interface)))
             .first;
  }
  return *it->second;
}

}  // namespace

std::error_code socketcan_error(std::string_view interface, int errno_value) {
  return {errno_value, category_for(interface)};
}

}  // namespace motion::can
