// One `simserial:` line in motion-sim: its end at <sim_runtime_dir>/<bus>.tty (a pty, or a Unix
// socket with `simulation.serial_link: socket`: motion::serial::SimLink; the gateway opens it like
// a real port), with the simulated device of the line's drive family on motion-sim's end.
// The host reads what the gateway writes and hands it to the device when it has crossed the
// line: the link moves bytes at once, so each read is delayed by its wire time at the bus's baud
// rate, after whatever is still on the line (a drive sees a frame when its last character ends,
// as on a real RS232/RS485 line). It writes the device's bytes once they have crossed the line the
// same way (their wire time, after the device's delay and after what is on the line). On a
// half-duplex line (RS485) both directions share the wire; a full-duplex one (RS232) has a wire
// each way, so the gateway's bytes never wait for a reply or a notification coming back. It keeps
// ONE timer at the earliest of the device's next deadline, the next arrival and the next due write.
//
// A serial line carries one family (its own framing), as in the gateway: the first family of the
// bus's drives that has a factory is served; drives of other families are listed in missing().
// Line noise (sim_control_t LINE_NOISE for the bus, whatever the family): `value` bytes of a
// fixed pseudo-random sequence (the same in every run), written at once (between frames) or into
// the middle of the next frame the device sends.
// The host reads the link in a thread of its own when the loop runs on the steady clock: it dates
// each read by when the bytes came (a pty: its hand-over to the reader; a socket: the kernel's
// stamp of the gateway's send, at most 10 ms back), not by when the loop got to them, since a loop
// busy with the other buses of motion-sim dated the gateway's frames, and with them the drives'
// ground truth (SIM_REPORT), milliseconds late. The reads reach the loop through a
// LoopMailbox, in order; a time never goes back for the device (a read dated before what the
// device has already been advanced to arrives then). On another clock (a test's) the loop reads.
// Thread contract: the loop's thread only (construction, every call, destruction); the reader
// thread touches the link's read side and the mailbox only. No call blocks.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "motion/config/config.hpp"
#include "motion/core/event_loop.hpp"
#include "motion/core/loop_mailbox.hpp"
#include "motion/serial/sim_link.hpp"
#include "motion/sim/serial_device_sim.hpp"

namespace motion::sim {

class SerialLineHost {
 public:
  using Reporter = std::function<void(motionlcm::sim_report_t)>;
  using Factories = std::map<config::Family, SerialDeviceFactory>;

  // The family that would serve `bus` with `factories`; nullopt when none of its drives has one.
  [[nodiscard]] static std::optional<config::Family> family_for(const config::Config& config, const config::Bus& bus,
                                                                const Factories& factories);
  // Creates the line's end (simulation.serial_link), the device, and powers it up. nullptr with
  // `error` set when the line's end cannot be made, or no family of the bus has a factory (ENOTSUP). The link is
  // `link_path`, or <sim_runtime_dir>/<bus>.tty when empty (simserial:; a simulated uimessage:
  // bus links its device path).
  static std::unique_ptr<SerialLineHost> open(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                                              const Factories& factories, Reporter reporter, std::error_code& error,
                                              const std::string& link_path = {});
  ~SerialLineHost();
  SerialLineHost(const SerialLineHost&) = delete;
  SerialLineHost& operator=(const SerialLineHost&) = delete;

  [[nodiscard]] const std::string& name() const { return bus_.name; }
  [[nodiscard]] config::Family family() const { return family_; }
  [[nodiscard]] const std::string& link_path() const { return link_->link_path(); }
  [[nodiscard]] const std::vector<std::string>& missing() const { return missing_; }
  [[nodiscard]] std::size_t drive_count() const { return drive_count_; }
  // Applies a sim_control_t for one of this line's drives, or LINE_NOISE for the line. False
  // when not ours (or unsupported).
  bool control(const motionlcm::sim_control_t& control);

 private:
  SerialLineHost(EventLoop& loop, const config::Config& config, const config::Bus& bus, config::Family family);
  void send(std::span<const std::uint8_t> bytes, Duration delay);
  std::vector<std::uint8_t> noise(std::size_t count);
  void on_readable();
  // Bytes the gateway wrote, read at `read_at`: queued to arrive after their wire time.
  void on_bytes(std::span<const std::uint8_t> bytes, TimePoint read_at);
  void read_in_thread();
  // The device is advanced to `now` (or kept at a later time it already has): what it is given.
  TimePoint device_time(TimePoint now);
  void on_timer();
  void flush(TimePoint now);
  void deliver(TimePoint now);
  void reschedule();

  EventLoop& loop_;
  config::Bus bus_;
  config::Family family_;
  std::unique_ptr<serial::SimLink> link_;
  std::unique_ptr<SerialDeviceSim> device_;
  TimePoint device_deadline_ = kNever;
  std::multimap<TimePoint, std::vector<std::uint8_t>> outbox_;         // due time -> bytes
  std::deque<std::pair<TimePoint, std::vector<std::uint8_t>>> inbox_;  // arrival (end of wire time) -> bytes
  // When the gateway's last bytes (read from the link) and the device's last bytes end on the wire.
  // A half-duplex line (SerialDeviceSim::full_duplex) carries one direction at a time.
  TimePoint to_device_until_{};
  TimePoint from_device_until_{};
  EventLoop::TimerId timer_ = 0;
  std::vector<std::string> missing_;
  std::size_t drive_count_ = 0;
  std::minstd_rand noise_source_;             // default seed: one sequence for every run
  std::vector<std::uint8_t> noise_in_frame_;  // goes into the middle of the next frame sent
  TimePoint device_now_{};                    // the latest time the device was given
  std::unique_ptr<LoopMailbox> mailbox_;      // reads of the reader thread, to the loop
  int stop_fd_ = -1;                          // eventfd: ends the reader thread
  std::thread reader_;
};

}  // namespace motion::sim
