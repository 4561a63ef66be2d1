#include "motion/can/socketcan_cyclic.hpp"

#include <linux/can/bcm.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "motion/can/socketcan_error.hpp"
#include "socketcan_detail.hpp"

namespace motion::can {
namespace {

// bcm_msg_head ends in a flexible array, so head and frame are laid out by hand.
struct BcmMessage {
  alignas(8) unsigned char bytes[sizeof(bcm_msg_head) + sizeof(can_frame)]{};

  explicit BcmMessage(const bcm_msg_head& head) { std::memcpy(bytes, &head, sizeof head); }
  void set_frame(const can_frame& frame) { std::memcpy(bytes + sizeof(bcm_msg_head), &frame, sizeof frame); }
};

bcm_timeval to_bcm_timeval(std::chrono::microseconds period) {
  bcm_timeval tv{};
  tv.tv_sec = static_cast<long>(period.count() / 1'000'000);
  tv.tv_usec = static_cast<long>(period.count() % 1'000'000);
  return tv;
}

}  // namespace

SocketCanCyclic::~SocketCanCyclic() { close(); }

std::error_code SocketCanCyclic::open(std::string_view interface) {
  interface_ = std::string(interface);
  jobs_.clear();
  return reopen();
}

void SocketCanCyclic::close() { detail::UniqueFd(std::exchange(fd_, -1)).reset(); }

std::error_code SocketCanCyclic::setup(const Frame& frame, std::chrono::microseconds period, Timer timer) {
  if (fd_ < 0) return socketcan_error(interface_, EBADF);
  can_frame raw{};
  if (!detail::to_kernel_frame(frame, raw) || period.count() <= 0) return socketcan_error(interface_, EINVAL);
  bcm_msg_head head;  // zeroed by hand: clang -Wpedantic flags `{}` on its zero-length frames[0]
  std::memset(&head, 0, sizeof head);
  head.opcode = TX_SETUP;
  head.can_id = detail::kernel_id(frame.id, frame.extended);
  head.nframes = 1;
  if (timer == Timer::kRestart) {
    // count 0: ival2 from the start; TX_ANNOUNCE: first frame right away.
    head.flags = SETTIMER | STARTTIMER | TX_ANNOUNCE;
    head.ival2 = to_bcm_timeval(period);
  } else if (timer == Timer::kSet) {
    // A new ival2 without STARTTIMER: the running timer re-arms with it at its next run.
    head.flags = SETTIMER;
    head.ival2 = to_bcm_timeval(period);
  }
  BcmMessage message(head);
  message.set_frame(raw);
  if (::write(fd_, message.bytes, sizeof message.bytes) < 0) return detail::last_error(interface_);
  return {};
}

std::error_code SocketCanCyclic::start(const Frame& frame, std::chrono::microseconds period) {
  if (auto ec = setup(frame, period, Timer::kRestart)) return ec;
  jobs_[{frame.id, frame.extended}] = Job{frame, period};
  return {};
}

std::error_code SocketCanCyclic::set_period(std::uint32_t id, bool extended, std::chrono::microseconds period) {
  const auto job = jobs_.find({id, extended});
  if (job == jobs_.end()) return socketcan_error(interface_, ENOENT);
  if (auto ec = setup(job->second.frame, period, Timer::kSet)) return ec;
  job->second.period = period;
  return {};
}

std::error_code SocketCanCyclic::update(const Frame& frame) {
  const auto job = jobs_.find({frame.id, frame.extended});
  if (job == jobs_.end()) return socketcan_error(interface_, ENOENT);
  if (auto ec = setup(frame, job->second.period, Timer::kKeep)) return ec;
  job->second.frame = frame;
  return {};
}

std::error_code SocketCanCyclic::stop(std::uint32_t id, bool extended) {
  if (jobs_.erase({id, extended}) == 0) return socketcan_error(interface_, ENOENT);
  if (fd_ < 0) return {};
  bcm_msg_head head;  // zeroed by hand: clang -Wpedantic flags `{}` on its zero-length frames[0]
  std::memset(&head, 0, sizeof head);
  head.opcode = TX_DELETE;
  head.can_id = detail::kernel_id(id, extended);
  if (::write(fd_, &head, sizeof head) < 0) return detail::last_error(interface_);
  return {};
}

std::error_code SocketCanCyclic::reopen() {
  close();
  detail::UniqueFd fd;
  int ifindex = 0;
  if (auto ec = detail::open_can_socket(interface_, CAN_BCM, fd, ifindex)) return ec;
  fd_ = fd.release();
  for (const auto& [key, job] : jobs_) {
    if (auto ec = setup(job.frame, job.period, Timer::kRestart)) return ec;
  }
  return {};
}

}  // namespace motion::can
