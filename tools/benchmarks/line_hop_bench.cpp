// Line hop benchmark: how long a frame takes from the gateway's write() to motion-sim's read of
// it, on the two kinds of simulated link, in the same run:
//   * pty — a `simserial:` line (serial::PtyLink, raw, as motion-sim makes it; the writer opens
//     the link with serial::SerialPort as the gateway does). The kernel hands what is written to
//     a pty's slave to the master through the tty flip buffer, pushed by a kernel worker thread:
//     one more wake-up than a socket.
//   * socket — an AF_UNIX SOCK_SEQPACKET pair, the kind of link between a gateway and the
//     simulated CAN bus (simbus), whose hub dates a frame when it reads it.
// motion-sim dates a serial frame from its read (it cannot see the write), the CAN hub from its
// read too, so the difference of the two hops is how much later than a CAN drive a simulated
// serial drive acts on a start both gateways wrote on time: a lateness of the simulation, not of
// the product (a real UART starts shifting the frame when the driver has it).
//
// The reader is another process, blocked in epoll_wait like motion-sim's loop; the writer stamps
// each frame with CLOCK_MONOTONIC just before write() and alternates the two links, a frame every
// 0.3–1.5 ms (random). Two sittings: the host as it is, and with one busy thread per CPU beside
// (the lab's gateways and simulator keep a 2-core host about that busy). Figures: p50 / p99 of
// the hop; the bound is the socket hop of the same sitting, the ratio pty / socket.
//
// A third sitting models the lab under `--realtime`: the writer and the reader under SCHED_FIFO 50
// (the gateways), one thread per CPU under SCHED_FIFO 40 busy 1.5 ms out of every 2.5 ms (motion-sim
// and its bursts). The socket's reader is woken by the write itself; the pty's flip buffer waits
// for its kernel worker, a normal-priority thread that runs only when no real-time thread does.
// Skipped, and said, where SCHED_FIFO is not permitted.
//
// Usage: bench_line_hop [--quick]   (--quick: fewer frames, for a smoke run)
#include <pthread.h>
#include <sched.h>
#include <sys/epoll.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "bench_table.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/serial/serial_port.hpp"

namespace motion {
namespace {

using bench::fmt;
using bench::fmt2;
using bench::nearest_rank;

std::int64_t monotonic_ns() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000LL + ts.tv_nsec;
}

constexpr std::int64_t kEnd = -1;  // the stamp that ends a sitting (sent on the socket)

// What runs beside the links in a sitting.
struct Load {
  unsigned spinners = 0;  // busy threads
  int spinner_fifo = 0;   // their SCHED_FIFO priority (0: normal scheduling, busy all the time)
  int io_fifo = 0;        // the writer's and the reader's SCHED_FIFO priority (0: normal)
};
// Busy this long out of every kSpinOn + kSpinOff when the spinners are real-time.
constexpr auto kSpinOn = std::chrono::microseconds(1500);
constexpr auto kSpinOff = std::chrono::microseconds(1000);

// The calling thread under SCHED_FIFO `priority` (0: SCHED_OTHER); false when refused.
bool set_fifo(int priority) {
  sched_param param{};
  param.sched_priority = priority;
  return ::pthread_setschedparam(::pthread_self(), priority > 0 ? SCHED_FIFO : SCHED_OTHER, &param) == 0;
}

struct Hops {
  std::vector<double> pty_us;
  std::vector<double> socket_us;
};

// The reader (child process): epoll on the pty master and the socket, a hop per 8-byte stamp,
// until kEnd; then the hops, length-prefixed, to `out`.
[[noreturn]] void reader(int pty_master, int socket_fd, int out) {
  const int ep = ::epoll_create1(EPOLL_CLOEXEC);
  for (const int fd : {pty_master, socket_fd}) {
    epoll_event ev{};
    ev.events = EPOLLIN;
    ev.data.fd = fd;
    ::epoll_ctl(ep, EPOLL_CTL_ADD, fd, &ev);
  }
  std::vector<double> hops[2];
  std::vector<std::uint8_t> pending;  // a pty is a byte stream: stamps may come in pieces
  for (bool done = false; !done;) {
    std::array<epoll_event, 2> events{};
    const int n = ::epoll_wait(ep, events.data(), 2, 5000);
    if (n <= 0) break;  // the writer is gone
    for (const epoll_event& event : std::span(events).first(static_cast<std::size_t>(n))) {
      std::array<std::uint8_t, 256> buffer{};
      const ssize_t got = ::read(event.data.fd, buffer.data(), buffer.size());
      const std::int64_t now = monotonic_ns();
      if (got <= 0) continue;
      const bool pty = event.data.fd == pty_master;
      if (pty) pending.insert(pending.end(), buffer.begin(), buffer.begin() + got);
      const std::uint8_t* bytes = pty ? pending.data() : buffer.data();
      const std::size_t size = pty ? pending.size() : static_cast<std::size_t>(got);
      std::size_t used = 0;
      for (; used + 8 <= size; used += 8) {
        std::int64_t stamp = 0;
        std::memcpy(&stamp, bytes + used, 8);
        if (stamp == kEnd) {
          done = true;
          continue;
        }
        hops[pty ? 0 : 1].push_back(static_cast<double>(now - stamp) / 1000.0);
      }
      if (pty) pending.erase(pending.begin(), pending.begin() + static_cast<std::ptrdiff_t>(used));
    }
  }
  for (const auto& h : hops) {
    const std::uint64_t count = h.size();
    (void)!::write(out, &count, sizeof count);
    (void)!::write(out, h.data(), count * sizeof(double));
  }
  ::_exit(0);
}

bool read_all(int fd, void* data, std::size_t size) {
  auto* p = static_cast<char*>(data);
  while (size > 0) {
    const ssize_t n = ::read(fd, p, size);
    if (n <= 0) return false;
    p += n;
    size -= static_cast<std::size_t>(n);
  }
  return true;
}

// One sitting: `frames` stamps, alternating the links, with `load` beside.
bool sitting(int frames, const Load& load, Hops& hops) {
  const auto dir = std::filesystem::temp_directory_path() / ("motion-line-hop-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  std::error_code error;
  const serial::SerialSettings line = serial::line_settings(115200, 'N', 1);
  auto link = serial::PtyLink::create((dir / "line.tty").string(), line, error);
  if (!link) {
    std::fprintf(stderr, "pty: %s\n", error.message().c_str());
    return false;
  }
  auto port = serial::SerialPort::open(link->link_path(), line, error);
  int sockets[2] = {-1, -1};
  int pipe_fds[2] = {-1, -1};
  if (!port || ::socketpair(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0, sockets) != 0 || ::pipe(pipe_fds) != 0) {
    std::fprintf(stderr, "cannot open the links: %s\n", error ? error.message().c_str() : std::strerror(errno));
    return false;
  }
  const pid_t child = ::fork();
  if (child == 0) {
    ::close(pipe_fds[0]);
    if (load.io_fifo > 0) (void)set_fifo(load.io_fifo);
    reader(link->master_fd(), sockets[1], pipe_fds[1]);
  }
  ::close(pipe_fds[1]);
  ::close(sockets[1]);

  std::atomic<bool> stop{false};
  std::vector<std::thread> busy;
  for (unsigned i = 0; i < load.spinners; ++i) {
    busy.emplace_back([&stop, fifo = load.spinner_fifo] {
      std::uint64_t x = 1;
      if (fifo > 0 && !set_fifo(fifo)) return;
      while (!stop.load(std::memory_order_relaxed)) {
        const auto until = std::chrono::steady_clock::now() + kSpinOn;
        while (std::chrono::steady_clock::now() < until || fifo == 0) {
          x = x * 6364136223846793005ULL + 1;
          if (fifo == 0 && stop.load(std::memory_order_relaxed)) break;
        }
        if (fifo > 0) std::this_thread::sleep_for(kSpinOff);
      }
      if (x == 0) std::printf(" ");
    });
  }
  if (load.io_fifo > 0) (void)set_fifo(load.io_fifo);
  std::mt19937 random(7);
  std::uniform_int_distribution<int> gap_us(300, 1500);
  std::this_thread::sleep_for(std::chrono::milliseconds(100));  // the reader is in epoll_wait
  for (int i = 0; i < frames; ++i) {
    std::this_thread::sleep_for(std::chrono::microseconds(gap_us(random)));
    const std::int64_t stamp = monotonic_ns();
    std::array<std::uint8_t, 8> bytes{};
    std::memcpy(bytes.data(), &stamp, 8);
    if (i % 2 == 0) {
      if (port->write(bytes)) return false;
    } else if (::write(sockets[0], bytes.data(), bytes.size()) != 8) {
      return false;
    }
  }
  const std::int64_t end = kEnd;
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  (void)!::write(sockets[0], &end, sizeof end);
  stop = true;
  for (auto& t : busy) t.join();
  (void)set_fifo(0);

  bool ok = true;
  for (auto* h : {&hops.pty_us, &hops.socket_us}) {
    std::uint64_t count = 0;
    ok = ok && read_all(pipe_fds[0], &count, sizeof count);
    if (!ok) break;
    h->resize(count);
    ok = read_all(pipe_fds[0], h->data(), count * sizeof(double));
  }
  int status = 0;
  ::waitpid(child, &status, 0);
  ::close(pipe_fds[0]);
  ::close(sockets[0]);
  port.reset();
  link.reset();
  std::filesystem::remove_all(dir, error);
  return ok && hops.pty_us.size() * 2 >= static_cast<std::size_t>(frames) - 1;
}

}  // namespace
}  // namespace motion

int main(int argc, char** argv) {
  using namespace motion;
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  const int frames = quick ? 400 : 8000;
  const unsigned cpus = std::max(1U, std::thread::hardware_concurrency());
  std::printf("line hop benchmark: %u CPUs; %d frames per sitting, half on each link\n", cpus, frames);
  std::vector<bench::Row> rows;
  const bool fifo_permitted = [] {
    std::thread probe_thread;
    bool ok = false;
    probe_thread = std::thread([&ok] { ok = set_fifo(1); });
    probe_thread.join();
    return ok;
  }();
  const std::vector<std::pair<std::string, Load>> sittings{
      {"host as it is", {}},
      {"one busy thread per CPU", {cpus, 0, 0}},
      {"real-time: links FIFO 50, a FIFO 40 thread per CPU busy 60 %", {cpus, 40, 50}}};
  for (const auto& [when, load] : sittings) {
    if (load.io_fifo > 0 && !fifo_permitted) {
      std::printf("real-time sitting skipped: SCHED_FIFO is not permitted here\n");
      continue;
    }
    Hops hops;
    if (!sitting(frames, load, hops)) {
      std::printf("FAILED: a sitting lost frames or could not open its links\n");
      return 1;
    }
    for (const double q : {0.5, 0.99}) {
      const double pty = nearest_rank(hops.pty_us, q);
      const double socket = nearest_rank(hops.socket_us, q);
      const std::string p = q == 0.5 ? "p50" : "p99";
      rows.push_back({"write -> read, pty vs socket, " + p + ", " + when, fmt("%.1f us", pty), fmt("%.1f us", socket),
                      pty / socket, fmt("pty later by %.1f us", pty - socket)});
    }
    rows.push_back(
        {"  (" + when + ": frames per link)",
         fmt2("%.0f / %.0f", static_cast<double>(hops.pty_us.size()), static_cast<double>(hops.socket_us.size())), "",
         NAN, ""});
  }
  bench::print_rows(rows, "figure", "socket hop");
  return 0;
}
