// A CPU wake-up latency request: while a CpuLatencyRequest is held, the kernel keeps every CPU
// out of the idle states it cannot leave within `limit` (the PM QoS CPU latency interface,
// /dev/cpu_dma_latency: a 32-bit limit in microseconds, in force while the file stays open;
// Documentation/power/pm_qos_interface.rst). 0 keeps idle CPUs polling: a timer or a frame then
// wakes its thread without the CPU (or, in a virtual machine, the hypervisor) waking first, at the
// cost of the idle CPUs' power. It is system-wide: one process holding it serves every other
// process of the host; the kernel honours the lowest limit any process asks.
//
// Opening the file needs write permission on it (root, or a udev rule granting a group); a
// refused request changes nothing and says why (error()).
//
// Thread contract: any thread; the request holds no lock and is released by the destructor.
#pragma once

#include <chrono>
#include <system_error>

namespace motion {

class CpuLatencyRequest {
 public:
  // Asks for `limit` (not negative) on `device` (the default: the kernel's file; a test names
  // another).
  explicit CpuLatencyRequest(std::chrono::microseconds limit, const char* device = "/dev/cpu_dma_latency");
  ~CpuLatencyRequest();
  CpuLatencyRequest(const CpuLatencyRequest&) = delete;
  CpuLatencyRequest& operator=(const CpuLatencyRequest&) = delete;

  // true: the request is in force until this object is destroyed.
  [[nodiscard]] bool held() const { return fd_ >= 0; }
  // Why it is not (open or write refused); empty when held.
  [[nodiscard]] const std::error_code& error() const { return error_; }

 private:
  int fd_ = -1;
  std::error_code error_;
};

}  // namespace motion
