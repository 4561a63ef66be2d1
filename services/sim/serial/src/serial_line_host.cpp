#include "motion/sim/serial_line_host.hpp"

#include <poll.h>
#include <sys/eventfd.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>

#include <spdlog/spdlog.h>

#include "motion/core/unix_socket.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion::sim {
namespace {

// The configured line (baud, 'N'/'E'/'O' parity, stop bits; 8 data bits), as the gateway opens it.
serial::SerialSettings configured_line(const config::Bus& bus) {
  return serial::line_settings(bus.baud, bus.parity, bus.stop_bits);
}

}  // namespace

std::optional<config::Family> SerialLineHost::family_for(const config::Config& config, const config::Bus& bus,
                                                         const Factories& factories) {
  // In family order, as the gateway picks its serial driver (gateway/app/bus_assembly.cpp).
  for (const auto& entry : factories) {
    const config::Family family = entry.first;
    if (std::any_of(config.drives.begin(), config.drives.end(),
                    [&](const config::Drive& d) { return d.bus == bus.name && d.family == family; })) {
      return family;
    }
  }
  return std::nullopt;
}

SerialLineHost::SerialLineHost(EventLoop& loop, const config::Config& config, const config::Bus& bus,
                               config::Family family)
    : loop_(loop), bus_(bus), family_(family) {
  for (const auto& d : config.drives) {
    if (d.bus != bus.name) continue;
    if (d.family == family) {
      ++drive_count_;
    } else {
      missing_.push_back(d.name + " (" + std::string(config::to_string(d.family)) + ")");
    }
  }
}

std::unique_ptr<SerialLineHost> SerialLineHost::open(EventLoop& loop, const config::Config& config,
                                                     const config::Bus& bus, const Factories& factories,
                                                     Reporter reporter, std::error_code& error,
                                                     const std::string& link_path) {
  const auto family = family_for(config, bus, factories);
  if (!family) {
    error = std::make_error_code(std::errc::not_supported);
    return nullptr;
  }
  std::string why;
  const auto access = config::sim_file_access(config, &why);
  if (!access) {
    spdlog::error("simulated serial line {}: {}", bus.name, why);
    error = std::make_error_code(std::errc::invalid_argument);
    return nullptr;
  }
  auto host = std::unique_ptr<SerialLineHost>(new SerialLineHost(loop, config, bus, *family));
  const auto link_kind = config.simulation.serial_link == config::SimulationSettings::SerialLink::kSocket
                             ? serial::SimLinkKind::kSocket
                             : serial::SimLinkKind::kPty;
  host->link_ = serial::create_sim_link(
      link_kind, link_path.empty() ? serial::simserial_link_path(config::sim_runtime_dir(config), bus.name) : link_path,
      configured_line(bus), error, *access);
  if (!host->link_) return nullptr;
  SerialDeviceContext context;
  context.bus = bus.name;
  context.send = [h = host.get()](std::span<const std::uint8_t> bytes, Duration delay) { h->send(bytes, delay); };
  context.report = [reporter = std::move(reporter), bus_name = bus.name](const std::string& drive, std::int8_t kind,
                                                                         std::int64_t frame_utime,
                                                                         std::int64_t position, std::int64_t target) {
    if (!reporter) return;
    motionlcm::sim_report_t r{};
    r.utime = wall_time_us();
    r.drive = drive;
    r.bus = bus_name;
    r.kind = kind;
    r.frame_utime = frame_utime;
    r.position_counts = position;
    r.target_counts = target;
    reporter(std::move(r));
  };
  // One steady -> wall offset for the line's life: every report of one frame carries one time.
  const auto steady_us = [](TimePoint t) {
    return std::chrono::duration_cast<std::chrono::microseconds>(t.time_since_epoch()).count();
  };
  context.utime_of = [steady_us, offset = wall_time_us() - steady_us(loop.now())](TimePoint t) {
    return steady_us(t) + offset;
  };
  host->device_ = factories.at(*family)(config, bus, std::move(context));
  if (dynamic_cast<const SystemSteadyClock*>(&loop.clock()) != nullptr) {
    host->mailbox_ = std::make_unique<LoopMailbox>(loop);
    host->stop_fd_ = ::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK);
  }
  if (host->mailbox_ && host->mailbox_->ok() && host->stop_fd_ >= 0) {
    host->reader_ = std::thread([h = host.get()] { h->read_in_thread(); });
  } else {
    loop.watch(host->link_->fd(), [h = host.get()] { h->on_readable(); });
  }
  const TimePoint now = loop.now();
  host->device_->power_up(host->device_time(now));
  host->device_deadline_ = host->device_->process(now);
  host->reschedule();
  return host;
}

SerialLineHost::~SerialLineHost() {
  if (reader_.joinable()) {
    const std::uint64_t one = 1;
    (void)!::write(stop_fd_, &one, sizeof one);
    reader_.join();
  } else if (link_) {
    loop_.unwatch(link_->fd());
  }
  if (stop_fd_ >= 0) ::close(stop_fd_);
  mailbox_.reset();  // reads still queued are dropped
  if (timer_ != 0) loop_.cancel(timer_);
}

void SerialLineHost::send(std::span<const std::uint8_t> bytes, Duration delay) {
  std::vector<std::uint8_t> out(bytes.begin(), bytes.end());
  if (!noise_in_frame_.empty()) {
    out.insert(out.begin() + static_cast<std::ptrdiff_t>(out.size() / 2), noise_in_frame_.begin(),
               noise_in_frame_.end());
    noise_in_frame_.clear();
  }
  // The device's bytes cross the line too: written when their last character has, after the
  // device's delay and after whatever is still on the line (before, a reply arrived at once, and a
  // 19200-baud line carried more than its baud rate allows). The delay counts from the device's
  // own present (the arrival of the request it answers), not from when motion-sim got to run it:
  // a reply dated by a loop that was held up kept a half-duplex line busy past the gateway's next
  // frame, which then reached its drives that much late.
  TimePoint begin = std::max(from_device_until_, device_now_ + delay);
  if (!device_->full_duplex()) begin = std::max(begin, to_device_until_);
  from_device_until_ = begin + configured_line(bus_).wire_time(out.size());
  outbox_.emplace(from_device_until_, std::move(out));
}

std::vector<std::uint8_t> SerialLineHost::noise(std::size_t count) {
  std::vector<std::uint8_t> out(count);
  for (auto& b : out) b = static_cast<std::uint8_t>(noise_source_() & 0xFF);
  return out;
}

void SerialLineHost::on_readable() {
  std::array<std::uint8_t, 512> buffer{};
  const TimePoint now = loop_.now();
  for (;;) {
    std::int64_t sent_wall_ns = 0;  // not used: the loop's clock is not the real one here
    const std::size_t n = link_->read(buffer, sent_wall_ns);
    if (n == 0) break;
    on_bytes({buffer.data(), n}, now);
  }
  reschedule();
}

void SerialLineHost::on_bytes(std::span<const std::uint8_t> bytes, TimePoint read_at) {
  TimePoint begin = std::max(to_device_until_, read_at);
  if (!device_->full_duplex() && from_device_until_ > read_at) {
    // One exchange at a time on a half-duplex line: a gateway that writes while a drive still
    // sends would garble both on a real one. Said, since the frame is then dated that much late.
    spdlog::warn("bus {}: the gateway wrote {} bytes while a drive was still sending for {} us; they follow it",
                 bus_.name, bytes.size(),
                 std::chrono::duration_cast<std::chrono::microseconds>(from_device_until_ - read_at).count());
    begin = std::max(begin, from_device_until_);
  }
  to_device_until_ = begin + configured_line(bus_).wire_time(bytes.size());
  inbox_.emplace_back(to_device_until_, std::vector<std::uint8_t>(bytes.begin(), bytes.end()));
}

void SerialLineHost::read_in_thread() {
  // A socket's stamp dates the bytes by the gateway's send, at most this far back.
  constexpr Duration kLongestReadDelay = std::chrono::milliseconds(10);
  std::array<std::uint8_t, 512> buffer{};
  const auto post = [this](std::vector<std::uint8_t>& bytes, TimePoint sent) {
    if (bytes.empty()) return;
    const bool queued = mailbox_->post([this, bytes = std::move(bytes), sent] {
      on_bytes(bytes, sent);
      reschedule();
    });
    bytes.clear();
    if (!queued) spdlog::warn("bus {}: the loop is behind; bytes the gateway wrote were dropped", bus_.name);
  };
  for (;;) {
    std::array<pollfd, 2> fds{{{link_->fd(), POLLIN, 0}, {stop_fd_, POLLIN, 0}}};
    if (::poll(fds.data(), fds.size(), -1) < 0) {
      if (errno == EINTR) continue;
      spdlog::error("bus {}: the simulated line's reader stops: {}", bus_.name,
                    std::error_code(errno, std::generic_category()).message());
      return;
    }
    if (fds[1].revents != 0) return;
    const TimePoint read_at = loop_.clock().now();
    // Reads dated alike (all of a pty's) go to the device together; a socket's messages each
    // carry the time of their own send.
    std::vector<std::uint8_t> bytes;
    TimePoint bytes_sent = read_at;
    bool any = false;
    for (;;) {
      std::int64_t sent_wall_ns = 0;
      const std::size_t n = link_->read(buffer, sent_wall_ns);
      if (n == 0) break;
      any = true;
      const TimePoint sent = unix_socket::sent_time(read_at, sent_wall_ns, kLongestReadDelay);
      if (sent != bytes_sent) post(bytes, bytes_sent);
      bytes_sent = sent;
      bytes.insert(bytes.end(), buffer.begin(), buffer.begin() + static_cast<std::ptrdiff_t>(n));
    }
    post(bytes, bytes_sent);
    // Readable without bytes (a pty hang-up the kept slave fd should prevent; a socket whose
    // connections came or went, handled by the read): do not spin on a hang-up.
    if (!any && (fds[0].revents & (POLLHUP | POLLERR)) != 0) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
}

TimePoint SerialLineHost::device_time(TimePoint now) {
  device_now_ = std::max(device_now_, now);
  return device_now_;
}

void SerialLineHost::deliver(TimePoint now) {
  while (!inbox_.empty() && inbox_.front().first <= now) {
    const auto& [arrival, bytes] = inbox_.front();
    device_deadline_ = device_->receive(bytes, device_time(arrival));
    inbox_.pop_front();
  }
}

void SerialLineHost::on_timer() {
  timer_ = 0;
  const TimePoint now = loop_.now();
  deliver(now);
  device_deadline_ = device_->process(device_time(now));
  reschedule();
}

bool SerialLineHost::control(const motionlcm::sim_control_t& control) {
  const TimePoint now = loop_.now();
  if (control.action == motionlcm::sim_control_t::LINE_NOISE) {
    if (!control.drive.empty() || control.bus != bus_.name || control.value <= 0) return false;
    auto bytes = noise(static_cast<std::size_t>(control.value));
    spdlog::info("bus {}: {} noise bytes {}", bus_.name, bytes.size(),
                 control.level != 0 ? "into the next frame" : "on the line");
    if (control.level != 0) {
      noise_in_frame_ = std::move(bytes);
    } else {
      outbox_.emplace(now, std::move(bytes));
      reschedule();
    }
    return true;
  }
  if (!device_->control(control, device_time(now))) return false;
  device_deadline_ = device_->process(now);
  reschedule();
  return true;
}

void SerialLineHost::flush(TimePoint now) {
  while (!outbox_.empty() && outbox_.begin()->first <= now) {
    const auto& bytes = outbox_.begin()->second;
    if (const auto error = link_->write(bytes))
      spdlog::warn("bus {}: {} bytes not written: {}", bus_.name, bytes.size(), error.message());
    outbox_.erase(outbox_.begin());
  }
}

void SerialLineHost::reschedule() {
  flush(loop_.now());
  if (timer_ != 0) loop_.cancel(timer_);
  timer_ = 0;
  TimePoint next = outbox_.empty() ? device_deadline_ : std::min(device_deadline_, outbox_.begin()->first);
  if (!inbox_.empty()) next = std::min(next, inbox_.front().first);
  if (next == kNever) return;
  timer_ = loop_.call_at(next, [this] { on_timer(); });
}

}  // namespace motion::sim
