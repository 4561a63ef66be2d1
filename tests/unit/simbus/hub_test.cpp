// The hub and its endpoints over real Unix sockets, all on one EventLoop in this process.
#include "motion/simbus/hub.hpp"

#include <gtest/gtest.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <variant>
#include <vector>

#include "motion/can_frame/bit_timing.hpp"
#include "motion/simbus/address.hpp"
#include "motion/simbus/wire.hpp"
#include "motion/testing/temp_dir.hpp"

namespace motion::simbus {
namespace {

using std::chrono::microseconds;
using std::chrono::milliseconds;

// A private socket directory per test.
using TempDir = testing::TempDir;

bool run_until(EventLoop& loop, const std::function<bool()>& done, Duration timeout = std::chrono::seconds(3)) {
  const TimePoint deadline = SteadyClock::now() + timeout;
  while (!done()) {
    if (SteadyClock::now() > deadline) return false;
    loop.run_once(milliseconds(5));
  }
  return true;
}

// Watches one transport on the loop and keeps what it receives.
class Receiver {
 public:
  Receiver(EventLoop& loop, can::Transport& transport) : loop_(loop), transport_(transport), fd_(transport.fd()) {
    transport_.on_bus_event([this](const can::BusEvent& e) { events.push_back(e); });
    loop_.watch(fd_, [this] {
      ++wakeups;
      while (auto f = transport_.receive()) frames.push_back(*f);
    });
  }
  ~Receiver() { loop_.unwatch(fd_); }
  Receiver(const Receiver&) = delete;
  Receiver& operator=(const Receiver&) = delete;

  [[nodiscard]] std::vector<std::uint32_t> ids() const {
    std::vector<std::uint32_t> out;
    for (const auto& f : frames) out.push_back(f.id);
    return out;
  }
  std::vector<can::Frame> frames;
  std::vector<can::BusEvent> events;
  int wakeups = 0;

 private:
  EventLoop& loop_;
  can::Transport& transport_;
  int fd_;
};

can::Frame frame(std::uint32_t id, std::vector<std::uint8_t> payload = {}) {
  return can::Frame::make(id, false, payload).value();
}

// A peer speaking the wire protocol itself over a raw socket: a test hub (listen) or a sender
// (connect) that chooses each frame's hand-over stamp and when its datagram goes.
class RawPeer {
 public:
  static RawPeer connect_to(const std::filesystem::path& path) {
    RawPeer peer(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
    const sockaddr_un address = address_of(path);
    if (::connect(peer.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0) {
      throw std::runtime_error("connect: " + std::string(std::strerror(errno)));
    }
    return peer;
  }
  static RawPeer listen_at(const std::filesystem::path& path) {
    RawPeer peer(::socket(AF_UNIX, SOCK_SEQPACKET | SOCK_CLOEXEC, 0));
    const sockaddr_un address = address_of(path);
    if (::bind(peer.fd_, reinterpret_cast<const sockaddr*>(&address), sizeof address) != 0 ||
        ::listen(peer.fd_, 1) != 0) {
      throw std::runtime_error("bind: " + std::string(std::strerror(errno)));
    }
    return peer;
  }
  RawPeer(RawPeer&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  RawPeer(const RawPeer&) = delete;
  RawPeer& operator=(const RawPeer&) = delete;
  RawPeer& operator=(RawPeer&&) = delete;
  ~RawPeer() {
    if (fd_ >= 0) ::close(fd_);
  }
  RawPeer accept() const { return RawPeer(::accept4(fd_, nullptr, nullptr, SOCK_CLOEXEC)); }
  void send(const wire::Message& message) const {
    std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
    const std::size_t size = wire::encode(message, buffer);
    if (size == 0 || ::send(fd_, buffer.data(), size, MSG_NOSIGNAL) != static_cast<ssize_t>(size)) {
      throw std::runtime_error("send failed");
    }
  }
  void send_frame(can::Frame f, std::int64_t handed_over_us) const {
    f.timestamp_us = handed_over_us;
    send(wire::FrameMessage{f, false});
  }
  // The next message (blocking).
  wire::Message receive() const { return *receive_with(0); }
  // The next message if one is waiting.
  std::optional<wire::Message> try_receive() const { return receive_with(MSG_DONTWAIT); }

 private:
  explicit RawPeer(int fd) : fd_(fd) {
    if (fd_ < 0) throw std::runtime_error("socket: " + std::string(std::strerror(errno)));
  }
  std::optional<wire::Message> receive_with(int flags) const {
    std::array<std::uint8_t, wire::kMaxMessageSize> buffer{};
    const ssize_t size = ::recv(fd_, buffer.data(), buffer.size(), flags);
    if (size < 0 && errno == EAGAIN && (flags & MSG_DONTWAIT) != 0) return std::nullopt;
    if (size <= 0) throw std::runtime_error("receive failed");
    auto message = wire::decode({buffer.data(), static_cast<std::size_t>(size)});
    if (!message) throw std::runtime_error("malformed message");
    return message;
  }
  static sockaddr_un address_of(const std::filesystem::path& path) {
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof address.sun_path - 1);
    return address;
  }
  int fd_;
};

// How far a wall-clock time may move on its way to the hub's loop clock and back (two clock reads
// each way).
constexpr std::int64_t kClockConversionUs = 50;

class HubTest : public ::testing::Test {
 protected:
  void open_hub(BusConfig config = {}) {
    std::error_code error;
    hub = Hub::open(loop, HubOptions{"lab", dir.path(), true, config, {}}, error);
    ASSERT_TRUE(hub) << error.message();
  }
  std::unique_ptr<SocketEndpoint> connect(const std::string& label, bool own_echo = false) {
    std::error_code error;
    auto endpoint = SocketEndpoint::connect("lab", EndpointOptions{dir.path(), label, own_echo}, error);
    EXPECT_TRUE(endpoint) << error.message();
    return endpoint;
  }
  void wait_attached(std::size_t count) {
    ASSERT_TRUE(run_until(loop, [&] { return hub->endpoints().size() == count; }));
  }
  EndpointId id_of(const std::string& label) const { return hub->find_endpoint(label).value_or(0); }
  // The hub with two socket endpoints attached, sender ("tx") and listener ("rx"), and what the
  // listener receives in heard.
  void open_with_pair() {
    open_hub();
    sender = connect("tx");
    listener = connect("rx");
    heard = std::make_unique<Receiver>(loop, *listener);
    wait_attached(2);
  }

  TempDir dir{"simbus"};
  EventLoop loop;
  std::unique_ptr<Hub> hub;
  std::unique_ptr<SocketEndpoint> sender;
  std::unique_ptr<SocketEndpoint> listener;
  std::unique_ptr<Receiver> heard;
};

// Whoever can connect to a bus socket can put frames on the bus: it is its owner's alone (0600,
// whatever the umask), or also one configured group's (0660).
TEST_F(HubTest, SocketIsItsOwnersAloneOrAlsoTheConfiguredGroups) {
  open_hub();
  struct stat st {};
  ASSERT_EQ(::stat(hub->socket_path().c_str(), &st), 0);
  EXPECT_TRUE(S_ISSOCK(st.st_mode));
  EXPECT_EQ(st.st_mode & 07777, 0600U);
  std::error_code error;
  auto grouped = Hub::open(loop, HubOptions{"lab2", dir.path(), true, {}, FileAccess{::getgid()}}, error);
  ASSERT_TRUE(grouped) << error.message();
  ASSERT_EQ(::stat(grouped->socket_path().c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 07777, 0660U);
  EXPECT_EQ(st.st_gid, ::getgid());
  // Still a working bus for its owner.
  auto endpoint = SocketEndpoint::connect("lab", EndpointOptions{dir.path(), "owner", false}, error);
  EXPECT_TRUE(endpoint) << error.message();
}

TEST_F(HubTest, EveryFrameReachesEveryOtherEndpointAcrossSocketsAndInProcess) {
  open_hub();
  EXPECT_EQ(hub->socket_path(), dir.path() / "motion-simbus-lab.sock");
  auto one = connect("one");
  auto two = connect("two");
  auto three = connect("three");
  auto drive = hub->attach_local("drive");
  ASSERT_TRUE(one && two && three && drive);
  Receiver r1(loop, *one), r2(loop, *two), r3(loop, *three), rd(loop, *drive);
  wait_attached(4);
  ASSERT_TRUE(run_until(loop, [&] { return one->endpoint_id() != 0 && three->endpoint_id() != 0; }));
  EXPECT_EQ(one->endpoint_id(), id_of("one"));
  EXPECT_EQ(one->name(), "sim:lab");

  ASSERT_FALSE(one->send(frame(0x101, {1})));
  ASSERT_FALSE(two->send(frame(0x102, {2})));
  ASSERT_FALSE(three->send(frame(0x103, {3})));
  ASSERT_FALSE(drive->send(frame(0x104, {4})));
  ASSERT_TRUE(run_until(loop, [&] {
    return r1.frames.size() == 3 && r2.frames.size() == 3 && r3.frames.size() == 3 && rd.frames.size() == 3;
  }));
  loop.run_once(milliseconds(20));  // nothing more may arrive (in particular no own frames)
  auto sorted = [](std::vector<std::uint32_t> v) {
    std::sort(v.begin(), v.end());
    return v;
  };
  EXPECT_EQ(sorted(r1.ids()), (std::vector<std::uint32_t>{0x102, 0x103, 0x104}));
  EXPECT_EQ(sorted(r2.ids()), (std::vector<std::uint32_t>{0x101, 0x103, 0x104}));
  EXPECT_EQ(sorted(r3.ids()), (std::vector<std::uint32_t>{0x101, 0x102, 0x104}));
  EXPECT_EQ(sorted(rd.ids()), (std::vector<std::uint32_t>{0x101, 0x102, 0x103}));
  EXPECT_EQ(one->statistics().tx_frames, 1u);
  EXPECT_EQ(one->statistics().rx_frames, 3u);
  EXPECT_EQ(one->statistics().rx_bytes, 3u);
  EXPECT_EQ(hub->statistics().frames, 4u);
}

class HubBitrate : public HubTest, public ::testing::WithParamInterface<std::uint32_t> {};

TEST_P(HubBitrate, BackToBackFramesAreStampedOneFrameTimeApart) {
  BusConfig config;
  config.bitrate = GetParam();
  open_hub(config);
  auto tx = connect("tx");
  auto rx = connect("rx");
  Receiver received(loop, *rx);
  Receiver sent(loop, *tx);
  wait_attached(2);
  const std::vector<can::Frame> frames{frame(0x601, {0x40, 0x41, 0x60, 0, 0, 0, 0, 0}), frame(0x601, {}),
                                       frame(0x601, {0xFF, 0xFF, 0xFF}), frame(0x601, std::vector<std::uint8_t>(8, 0))};
  const std::int64_t before = wall_time_us();
  for (const auto& f : frames) ASSERT_FALSE(tx->send(f));
  ASSERT_TRUE(run_until(loop, [&] { return received.frames.size() == frames.size(); }));
  for (std::size_t i = 1; i < frames.size(); ++i) {
    EXPECT_EQ(microseconds(received.frames[i].timestamp_us - received.frames[i - 1].timestamp_us),
              can::frame_duration(frames[i], GetParam()))
        << "frame " << i;
  }
  // Timestamps are wall-clock end-of-frame times: after the send, and not far in the future.
  EXPECT_GE(received.frames.front().timestamp_us, before);
  EXPECT_LT(received.frames.back().timestamp_us, wall_time_us() + 100'000);
  EXPECT_GT(hub->statistics().bus_load, 0.0);
  EXPECT_EQ(rx->bitrate(), GetParam());
}

// A batch (one sendmmsg) reaches the bus in order, frame by frame, each counted as sent; a frame
// the bus cannot carry stops it there with send()'s error, the frames before it sent.
TEST_F(HubTest, ABatchOfFramesGoesOutInOrderAndStopsAtARefusal) {
  open_with_pair();
  const Receiver& received = *heard;
  std::vector<can::Frame> frames;
  for (std::uint32_t i = 0; i < 40; ++i) frames.push_back(frame(0x100 + i, {static_cast<std::uint8_t>(i)}));
  std::error_code error;
  ASSERT_EQ(sender->send_batch(frames, error), frames.size()) << error.message();
  ASSERT_TRUE(run_until(loop, [&] { return received.frames.size() == frames.size(); }));
  for (std::size_t i = 0; i < frames.size(); ++i) EXPECT_EQ(received.frames[i].id, frames[i].id) << "frame " << i;
  EXPECT_EQ(sender->statistics().tx_frames, frames.size());

  can::Frame too_long = frame(0x7FF);
  too_long.id = 0x800;  // beyond 11 bits
  const std::vector<can::Frame> refused{frame(0x201), too_long, frame(0x202)};
  EXPECT_EQ(sender->send_batch(refused, error), 1u);
  EXPECT_EQ(error, std::make_error_code(std::errc::invalid_argument));
  ASSERT_TRUE(run_until(loop, [&] { return received.frames.size() == frames.size() + 1; }));
  EXPECT_EQ(received.frames.back().id, 0x201u);
  EXPECT_EQ(sender->statistics().tx_dropped, 1u);
}

// A frame is on the wire from when its sender sent it, not from when the hub got to read it: the
// kernel stamps the datagram at the send (SO_TIMESTAMPNS). The hub's loop is kept away for 5 ms
// here (as when motion-sim is busy with the frames before); the frame ends one frame time after
// its send all the same.
TEST_F(HubTest, AFrameReadLateIsOnTheWireFromItsSend) {
  open_with_pair();
  const Receiver& received = *heard;
  const can::Frame f = frame(0x181, {1, 2, 3, 4});
  const std::int64_t sent = wall_time_us();
  ASSERT_FALSE(sender->send(f));
  ::usleep(5000);  // the loop is busy elsewhere
  ASSERT_TRUE(run_until(loop, [&] { return !received.frames.empty(); }));
  const auto end_of_frame = sent + std::chrono::duration_cast<microseconds>(can::frame_duration(f, 500000)).count();
  EXPECT_LT(received.frames[0].timestamp_us - end_of_frame, 2'000) << "dated by the hub's read, 5 ms late";
  EXPECT_GT(received.frames[0].timestamp_us - end_of_frame, -1'000);
}

// A batch reaches the hub as messages of up to 16 frames, each taken by the bus at once: frames
// sent as separate datagrams left gaps on the wire whenever the hub's wake-up on the first one
// preempted the sender (in 6 of 12 demo moves, up to 0.9 ms), and a frame of another endpoint
// took the idle wire meanwhile. An invalid frame stops the batch there, the frames before it sent.
TEST_F(HubTest, AnEndpointHandsABatchOverInMessagesOfUpTo16Frames) {
  const RawPeer listening = RawPeer::listen_at(socket_path("lab", dir.path()));
  std::error_code error;
  auto endpoint = SocketEndpoint::connect("lab", EndpointOptions{dir.path(), "tx", false}, error);
  ASSERT_TRUE(endpoint) << error.message();
  const RawPeer hub_side = listening.accept();
  ASSERT_TRUE(std::holds_alternative<wire::Hello>(hub_side.receive()));

  std::vector<can::Frame> frames;
  for (std::uint32_t i = 0; i < 20; ++i) frames.push_back(frame(0x200 + i, {static_cast<std::uint8_t>(i)}));
  ASSERT_EQ(endpoint->send_batch(frames, error), frames.size()) << error.message();
  std::vector<std::size_t> sizes;
  std::vector<can::Frame> got;
  while (got.size() < frames.size()) {
    const auto message = hub_side.receive();
    const auto* batch = std::get_if<wire::FrameBatch>(&message);
    ASSERT_NE(batch, nullptr) << "a frame of the batch came in a message of its own";
    sizes.push_back(batch->count);
    got.insert(got.end(), batch->view().begin(), batch->view().end());
  }
  EXPECT_EQ(sizes, (std::vector<std::size_t>{16, 4}));
  EXPECT_EQ(got, frames);
  EXPECT_EQ(endpoint->statistics().tx_frames, frames.size());

  can::Frame too_long = frame(0x7FF);
  too_long.id = 0x800;  // beyond 11 bits
  const std::vector<can::Frame> refused{frame(0x301), frame(0x302), too_long, frame(0x303)};
  EXPECT_EQ(endpoint->send_batch(refused, error), 2u);
  EXPECT_EQ(error, std::make_error_code(std::errc::invalid_argument));
  const auto message = hub_side.receive();
  const auto* batch = std::get_if<wire::FrameBatch>(&message);
  ASSERT_NE(batch, nullptr);
  EXPECT_EQ(batch->view().size(), 2u);
  EXPECT_EQ(endpoint->statistics().tx_dropped, 1u);
}

// The frames of one batch message take the wire back to back from the message's send, though
// the hub reads it late; a frame the bus refuses (its sender bus-off) comes back as TxRejected.
TEST_F(HubTest, ABatchMessageTakesTheWireBackToBackFromItsSend) {
  open_hub();
  listener = connect("rx");
  heard = std::make_unique<Receiver>(loop, *listener);
  const RawPeer raw = RawPeer::connect_to(hub->socket_path());
  raw.send(wire::Hello{wire::kProtocolVersion, false, "raw"});
  wait_attached(2);
  ASSERT_TRUE(std::holds_alternative<wire::Welcome>(raw.receive()));
  wire::FrameBatch batch;
  batch.frames[0] = frame(0x0A0);
  batch.frames[1] = frame(0x181, {1, 2, 3, 4});
  batch.frames[2] = frame(0x080);
  batch.count = 3;
  const std::int64_t sent = wall_time_us();
  raw.send(batch);
  ::usleep(3000);  // the hub's loop is busy elsewhere
  ASSERT_TRUE(run_until(loop, [&] { return heard->frames.size() == 3; }));
  const auto& got = heard->frames;
  EXPECT_EQ(heard->ids(), (std::vector<std::uint32_t>{0x0A0, 0x181, 0x080}))
      << "one endpoint's frames keep their order";
  EXPECT_LT(got[0].timestamp_us - sent, 1'000) << "dated by the hub's read, 3 ms late";
  for (std::size_t i = 1; i < 3; ++i) {
    EXPECT_EQ(microseconds(got[i].timestamp_us - got[i - 1].timestamp_us), can::frame_duration(batch.frames[i], 500000))
        << "frame " << i;
  }

  ASSERT_TRUE(hub->set_bus_off(id_of("raw")));
  raw.send(batch);
  std::vector<std::uint32_t> rejected;
  ASSERT_TRUE(run_until(loop, [&] {
    while (const auto message = raw.try_receive()) {
      if (const auto* r = std::get_if<wire::TxRejected>(&*message)) rejected.push_back(r->id);
    }
    return rejected.size() == 3;
  }));
  EXPECT_EQ(rejected, (std::vector<std::uint32_t>{0x0A0, 0x181, 0x080}));
  EXPECT_EQ(heard->frames.size(), 3u);
}

INSTANTIATE_TEST_SUITE_P(Bitrates, HubBitrate, ::testing::Values(125'000u, 500'000u, 1'000'000u));

// A gateway's endpoint reports the bus load it sees (health, motionctl health): the wire time of
// the frames it sent and received against the hub's bit rate. It read 0 % at 500 frames/s.
TEST_F(HubTest, EndpointsReportTheBusLoadOfTheFramesTheySaw) {
  BusConfig config;
  config.bitrate = 125'000;
  open_hub(config);
  auto tx = connect("tx");
  auto rx = connect("rx");
  Receiver received(loop, *rx);
  Receiver sent(loop, *tx);
  wait_attached(2);
  ASSERT_TRUE(run_until(loop, [&] { return rx->bitrate() == 125'000u && tx->bitrate() == 125'000u; }));
  EXPECT_EQ(rx->statistics().bus_load, 0.0);
  std::uint64_t bits = 0;
  for (int i = 0; i < 50; ++i) {
    const auto f = frame(0x181, std::vector<std::uint8_t>(8, static_cast<std::uint8_t>(i)));
    bits += can::LoadMeter::nominal_bits(f);
    ASSERT_FALSE(tx->send(f));
  }
  ASSERT_TRUE(run_until(loop, [&] { return received.frames.size() == 50; }));
  // Once the window has been open a second, each endpoint's load is its frames' wire time over
  // that second or more: at most bits / bitrate, and not zero.
  run_until(
      loop, [] { return false; }, milliseconds(1050));
  const double at_most = static_cast<double>(bits) / 125'000.0;
  for (auto* e : {rx.get(), tx.get()}) {
    const double load = e->statistics().bus_load;
    EXPECT_GT(load, 0.0) << e->name();
    EXPECT_LE(load, at_most * (1 + 1e-9)) << e->name();
  }
}

TEST_F(HubTest, OwnEchoAndFiltersArePerEndpoint) {
  open_hub();
  auto tx = connect("tx");
  auto rx = connect("rx");
  auto local = hub->attach_local("local", /*own_echo=*/true);
  Receiver at_tx(loop, *tx), at_rx(loop, *rx), at_local(loop, *local);
  wait_attached(3);
  ASSERT_FALSE(tx->set_own_echo(true));
  ASSERT_FALSE(rx->set_filters({can::Filter{0x200, 0x7FF, false, true}}));
  ASSERT_FALSE(tx->send(frame(0x100)));
  ASSERT_FALSE(tx->send(frame(0x200)));
  ASSERT_FALSE(local->send(frame(0x300)));
  ASSERT_TRUE(run_until(loop, [&] { return at_tx.frames.size() == 3 && at_local.frames.size() == 3; }));
  loop.run_once(milliseconds(20));
  // The local send reaches the bus at once; the hub reads tx's socket only on the next poll.
  EXPECT_EQ(at_tx.ids(), (std::vector<std::uint32_t>{0x300, 0x100, 0x200}));     // own two echoed
  EXPECT_EQ(at_local.ids(), (std::vector<std::uint32_t>{0x300, 0x100, 0x200}));  // own echo too
  EXPECT_EQ(at_rx.ids(), (std::vector<std::uint32_t>{0x200}));                   // filter
  EXPECT_EQ(rx->statistics().rx_frames, 1u);
}

TEST_F(HubTest, CorruptedFrameIsAnErrorEventNotAFrame) {
  open_hub();
  auto tx = connect("tx");
  auto rx = connect("rx");
  Receiver at_tx(loop, *tx), at_rx(loop, *rx);
  wait_attached(2);
  hub->inject(Fault::corrupt(1));
  ASSERT_FALSE(tx->send(frame(0x123, {0xAA})));
  ASSERT_FALSE(tx->send(frame(0x124)));
  ASSERT_TRUE(run_until(loop, [&] { return at_rx.frames.size() == 1 && !at_tx.events.empty(); }));
  EXPECT_EQ(at_rx.frames[0].id, 0x124u);
  ASSERT_EQ(at_rx.events.size(), 1u);
  EXPECT_EQ(at_rx.events[0].error_class, kErrorProtocol);
  EXPECT_EQ(rx->statistics().errors, 1u);
  EXPECT_EQ(tx->statistics().errors, 1u);
  EXPECT_EQ(hub->statistics().errors, 1u);
  EXPECT_EQ(rx->state(), can::BusState::kErrorActive);
}

TEST_F(HubTest, DropAndDelayFaultsApplyToSocketTraffic) {
  open_with_pair();
  hub->inject(Fault::drop(1));
  hub->inject(Fault::delay_by(milliseconds(30), 1, {can::Filter{0x002, 0x7FF}}));
  for (std::uint32_t id = 1; id <= 3; ++id) ASSERT_FALSE(sender->send(frame(id)));
  ASSERT_TRUE(run_until(loop, [&] { return heard->frames.size() == 2; }));
  EXPECT_EQ(heard->ids(), (std::vector<std::uint32_t>{0x003, 0x002}));
  EXPECT_GE(heard->frames[1].timestamp_us - heard->frames[0].timestamp_us, 30'000 - 200);
  EXPECT_EQ(hub->statistics().dropped, 1u);
}

TEST_F(HubTest, BusOffEndpointFailsSendsUntilRecovered) {
  open_hub();
  auto tx = connect("tx");
  auto rx = connect("rx");
  Receiver at_tx(loop, *tx), at_rx(loop, *rx);
  wait_attached(2);
  ASSERT_TRUE(hub->set_bus_off(id_of("tx")));
  // Sent before tx has heard about it: the hub refuses it and tells tx.
  ASSERT_FALSE(tx->send(frame(0x111)));
  ASSERT_TRUE(
      run_until(loop, [&] { return tx->state() == can::BusState::kBusOff && tx->statistics().tx_dropped == 1; }));
  EXPECT_EQ(tx->send(frame(0x112)), std::errc::network_down);
  ASSERT_EQ(at_tx.events.size(), 1u);
  EXPECT_EQ(at_tx.events[0].error_class, kErrorBusOff);
  EXPECT_EQ(tx->statistics().bus_off_count, 1u);
  EXPECT_EQ(tx->statistics().tx_dropped, 2u);

  ASSERT_TRUE(hub->recover(id_of("tx")));
  ASSERT_TRUE(run_until(loop, [&] { return tx->state() == can::BusState::kErrorActive; }));
  EXPECT_EQ(at_tx.events.back().error_class, kErrorRestarted);
  ASSERT_FALSE(tx->send(frame(0x113)));
  ASSERT_TRUE(run_until(loop, [&] { return !at_rx.frames.empty(); }));
  EXPECT_EQ(at_rx.ids(), (std::vector<std::uint32_t>{0x113}));

  // Automatic recovery after a given time.
  ASSERT_TRUE(hub->set_bus_off(id_of("tx"), milliseconds(30)));
  ASSERT_TRUE(run_until(loop, [&] { return tx->state() == can::BusState::kBusOff; }));
  ASSERT_TRUE(run_until(loop, [&] { return tx->state() == can::BusState::kErrorActive; }));
}

TEST_F(HubTest, LocalEndpointSeesBusOffAtOnce) {
  open_hub();
  auto drive = hub->attach_local("drive");
  Receiver at_drive(loop, *drive);
  ASSERT_TRUE(hub->set_bus_off(drive->endpoint_id()));
  EXPECT_EQ(drive->state(), can::BusState::kBusOff);
  EXPECT_EQ(drive->send(frame(0x1)), std::errc::network_down);
  ASSERT_TRUE(run_until(loop, [&] { return !at_drive.events.empty(); }));
  EXPECT_EQ(at_drive.events[0].state, can::BusState::kBusOff);
  EXPECT_EQ(drive->statistics().bus_off_count, 1u);
  ASSERT_TRUE(hub->recover(drive->endpoint_id()));
  EXPECT_FALSE(drive->send(frame(0x1)));
}

TEST_F(HubTest, DisconnectCutsOffSocketAndLocalEndpoints) {
  open_hub();
  auto gateway = connect("gateway");
  auto drive = hub->attach_local("drive");
  Receiver at_gateway(loop, *gateway), at_drive(loop, *drive);
  wait_attached(2);
  ASSERT_TRUE(hub->disconnect(id_of("gateway")));
  ASSERT_TRUE(hub->disconnect(drive->endpoint_id()));
  EXPECT_FALSE(hub->disconnect(999));
  ASSERT_TRUE(run_until(loop, [&] { return !at_gateway.events.empty() && !at_drive.events.empty(); }));
  for (can::Transport* t : {static_cast<can::Transport*>(gateway.get()), static_cast<can::Transport*>(drive.get())}) {
    EXPECT_EQ(t->state(), can::BusState::kDisconnected);
    EXPECT_EQ(t->fd(), -1);
    EXPECT_EQ(t->send(frame(0x1)), std::errc::not_connected);
  }
  EXPECT_EQ(at_gateway.events[0].state, can::BusState::kDisconnected);
  EXPECT_TRUE(hub->endpoints().empty());
  // The loop still watches the old descriptor numbers: they must stay quiet, not spin.
  const int wakeups = at_gateway.wakeups + at_drive.wakeups;
  loop.call_after(milliseconds(30), [&] { loop.stop(); });
  const std::uint64_t errors = loop.run();
  EXPECT_EQ(errors, 0u);
  EXPECT_EQ(at_gateway.events.size(), 1u);
  EXPECT_EQ(at_gateway.wakeups + at_drive.wakeups, wakeups);
}

// motion-sim's drives: a LocalEndpoint with a callback has no descriptor; the hub calls it from
// the loop after the bus has advanced (never inside a send), and a frame sent from the callback
// goes out like any other. Bus events and a disconnect reach it the same way.
TEST_F(HubTest, CallbackEndpointIsCalledFromTheLoopAndMayAnswerFromThere) {
  open_hub();
  auto gateway = hub->attach_local("gateway");
  auto drive = hub->attach_local("drive");
  Receiver at_gateway(loop, *gateway);
  std::vector<can::Frame> at_drive;
  std::vector<can::BusEvent> drive_events;
  bool inside_send = false;
  int calls_inside_send = 0;
  drive->on_bus_event([&](const can::BusEvent& e) { drive_events.push_back(e); });
  drive->on_ready([&] {
    if (inside_send) ++calls_inside_send;
    while (auto f = drive->receive()) {
      at_drive.push_back(*f);
      EXPECT_FALSE(drive->send(frame(f->id + 0x80, {0xAA})));  // answer from inside the callback
    }
  });
  EXPECT_EQ(drive->fd(), -1);
  inside_send = true;
  ASSERT_FALSE(gateway->send(frame(0x601, {1})));
  ASSERT_FALSE(gateway->send(frame(0x602, {2})));
  inside_send = false;
  ASSERT_TRUE(run_until(loop, [&] { return at_gateway.frames.size() == 2; }));
  EXPECT_EQ(calls_inside_send, 0);
  EXPECT_EQ(at_gateway.ids(), (std::vector<std::uint32_t>{0x681, 0x682}));
  ASSERT_EQ(at_drive.size(), 2u);
  EXPECT_EQ(at_drive[1].id, 0x602u);
  EXPECT_EQ(drive->statistics().rx_frames, 2u);

  ASSERT_TRUE(hub->set_bus_off(drive->endpoint_id()));
  ASSERT_TRUE(run_until(loop, [&] { return !drive_events.empty(); }));
  EXPECT_EQ(drive_events.back().state, can::BusState::kBusOff);
  ASSERT_TRUE(hub->disconnect(drive->endpoint_id()));
  ASSERT_TRUE(run_until(loop, [&] { return drive_events.back().state == can::BusState::kDisconnected; }));
  EXPECT_EQ(drive->state(), can::BusState::kDisconnected);
}

TEST_F(HubTest, EndpointsNoticeTheHubGoingAwayAndCanReconnect) {
  open_hub();
  auto gateway = connect("gateway");
  auto drive = hub->attach_local("drive");
  {
    Receiver at_gateway(loop, *gateway), at_drive(loop, *drive);
    wait_attached(2);
    hub.reset();
    ASSERT_TRUE(run_until(loop, [&] { return !at_gateway.events.empty() && !at_drive.events.empty(); }));
    EXPECT_EQ(gateway->state(), can::BusState::kDisconnected);
    EXPECT_EQ(drive->state(), can::BusState::kDisconnected);
    EXPECT_FALSE(std::filesystem::exists(dir.path() / "motion-simbus-lab.sock"));
  }
  EXPECT_TRUE(gateway->reconnect());  // no hub: fails
  open_hub();
  ASSERT_FALSE(gateway->reconnect());
  auto other = connect("other");
  Receiver at_gateway(loop, *gateway), at_other(loop, *other);
  wait_attached(2);
  ASSERT_FALSE(other->send(frame(0x42)));
  ASSERT_TRUE(run_until(loop, [&] { return !at_gateway.frames.empty(); }));
  EXPECT_EQ(gateway->state(), can::BusState::kErrorActive);
}

TEST_F(HubTest, OneHubPerBusAndStaleSocketsAreReplaced) {
  // A socket file nobody listens on (a crashed hub): bound, then closed without unlink.
  const auto path = socket_path("lab", dir.path());
  {
    const int fd = ::socket(AF_UNIX, SOCK_SEQPACKET, 0);
    sockaddr_un address{};
    address.sun_family = AF_UNIX;
    std::strncpy(address.sun_path, path.c_str(), sizeof(address.sun_path) - 1);
    ASSERT_EQ(::bind(fd, reinterpret_cast<const sockaddr*>(&address), sizeof address), 0);  // NOLINT
    ::close(fd);
  }
  open_hub();
  std::error_code error;
  EXPECT_FALSE(Hub::open(loop, HubOptions{"lab", dir.path(), true, {}, {}}, error));
  EXPECT_EQ(error, std::errc::address_in_use);
  EXPECT_FALSE(Hub::open(loop, HubOptions{"bad/name", dir.path(), true, {}, {}}, error));
  EXPECT_EQ(error, std::errc::invalid_argument);
}

TEST_F(HubTest, ConnectingToAMissingBusFails) {
  std::error_code error;
  EXPECT_FALSE(SocketEndpoint::connect("nobody", EndpointOptions{dir.path(), "x", false}, error));
  EXPECT_EQ(error, std::errc::no_such_file_or_directory);
  EXPECT_FALSE(SocketEndpoint::connect("", EndpointOptions{dir.path(), "x", false}, error));
  EXPECT_EQ(error, std::errc::invalid_argument);
}

TEST_F(HubTest, TimingOffDeliversWithoutWaiting) {
  BusConfig config;
  config.timing = false;
  open_hub(config);
  auto drive = hub->attach_local("drive");
  auto other = hub->attach_local("other");
  Receiver at_other(loop, *other);
  ASSERT_FALSE(drive->send(frame(0x7FF)));
  ASSERT_FALSE(drive->send(frame(0x001)));
  // Delivered inside send(): already waiting in the endpoint.
  auto first = other->receive();
  ASSERT_TRUE(first.has_value());
  EXPECT_EQ(first->id, 0x7FFu);  // no wire, no arbitration
  EXPECT_EQ(other->receive()->id, 0x001u);
  EXPECT_FALSE(other->receive().has_value());
}

TEST(SocketPath, DerivesFromTheBusNameAndTheEnvironment) {
  EXPECT_EQ(socket_path("lab", "/run/x"), std::filesystem::path("/run/x/motion-simbus-lab.sock"));
  ::setenv("MOTION_SIM_DIR", "/some/dir", 1);
  EXPECT_EQ(socket_path("can-1"), std::filesystem::path("/some/dir/motion-simbus-can-1.sock"));
  ::unsetenv("MOTION_SIM_DIR");
  EXPECT_TRUE(valid_bus_name("lab_2.x-y"));
  EXPECT_FALSE(valid_bus_name("a/b"));
  EXPECT_FALSE(valid_bus_name(std::string(65, 'a')));
}

}  // namespace
}  // namespace motion::simbus
