// libmodbus (Debian libmodbus5 3.1.x, an independent C implementation of Modbus RTU) as the
// interop peer of our ADAM pieces, over real pseudo-terminals (termios raw, 115200 8N1):
//  * LibmodbusClient.*: a libmodbus RTU CLIENT (modbus_new_rtu on the pty link AdamLineSim
//    publishes) against our simulated drives: 16-bit and 32-bit reads/writes (32-bit values in the
//    drive's LOW-WORD-FIRST order, decoded by hand: libmodbus's MODBUS_GET_INT32_FROM_INT16 assumes
//    high word first and is deliberately not used), Modbus exceptions for an undocumented register
//    and an unsupported function, and a broadcast (slave 0) table-execute that starts two drives
//    on the one frame without any reply;
//  * LibmodbusServer.*: a libmodbus RTU SERVER (modbus_receive/modbus_reply over a
//    modbus_mapping_t, in a std::thread) answering our AdamBusDriver/AdamStack: set-up, status
//    polling with a negative 32-bit position, 32-bit parameter write/read, an exception reply,
//    and a move started by our broadcast (which libmodbus executes and does not answer).
// libmodbus blocks its caller for a whole transaction, so it always runs on its own thread while
// the test thread pumps our EventLoop; every thread is joined in the test (or its TearDown).
#include <gtest/gtest.h>

#include <modbus.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <motionlcm/event_t.hpp>

#include "motion/adam/registers.hpp"
#include "motion/adam_driver/adam_bus_driver.hpp"
#include "motion/serial/pty_link.hpp"
#include "motion/sim/adam_line_sim.hpp"

namespace motion {
namespace {

using namespace std::chrono_literals;
using Reply = motionlcm::gateway_reply_t;
using Command = motionlcm::gateway_command_t;

// The drive's 32-bit order: register N holds the LOW 16 bits (registers.hpp).
std::int32_t low_word_first(const std::uint16_t* regs) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(regs[0]) | (static_cast<std::uint32_t>(regs[1]) << 16));
}
void put_low_word_first(std::uint16_t* regs, std::int32_t value) {
  const auto raw = static_cast<std::uint32_t>(value);
  regs[0] = static_cast<std::uint16_t>(raw & 0xFFFFU);
  regs[1] = static_cast<std::uint16_t>(raw >> 16);
}

std::string yaml_for(const std::filesystem::path& dir, int drives) {
  std::string yaml =
      "buses:\n"
      "  - {name: rs485, transport: 'simserial:rs485', baud: 115200, request_timeout_ms: 200, retries: 1, poll_hz: "
      "20}\n"
      "drives:\n";
  const char* names[] = {"c", "d"};
  for (int i = 0; i < drives; ++i) {
    yaml += "  - {name: " + std::string(names[i]) +
            "-drive, family: adam-modbus, bus: rs485, node_id: " + std::to_string(i + 1) + "}\n";
  }
  yaml += "axes:\n";
  for (int i = 0; i < drives; ++i) {
    yaml +=
        "  - {name: " + std::string(names[i]) + ", drive: " + names[i] +
        "-drive, unit: mm, steps_per_unit: 200, limits: {min: -1000, max: 1000, velocity: 100, acceleration: 1000}}\n";
  }
  // libmodbus loads table data without a Save: drives that execute unsaved data (a simulated
  // variant, docs/protocols.md), with the working speed and the target speed as one setpoint.
  yaml += "simulation: {runtime_dir: '" + dir.string() + "', reply_latency_us: 200, variants: {";
  for (int i = 0; i < drives; ++i) {
    yaml +=
        std::string(i == 0 ? "" : ", ") + names[i] + "-drive: {table_needs_save: false, table_speed_register: shared}";
  }
  yaml += "}}\n";
  return yaml;
}

struct Recorder final : gateway::GatewayOutput {
  std::vector<Reply> replies;
  std::vector<gateway::DriveEvent> events;
  std::vector<gateway::DriveStatus> statuses;
  void axis_status(const std::string&, const gateway::DriveStatus& s) override { statuses.push_back(s); }
  void axis_event(const std::string&, const gateway::DriveEvent& e) override { events.push_back(e); }
  void command_reply(Reply r) override { replies.push_back(std::move(r)); }
  [[nodiscard]] const Reply* terminal(std::int64_t id) const {
    for (const auto& r : replies) {
      if (r.command_id == id && (r.status == std::int8_t{Reply::DONE} || r.status == std::int8_t{Reply::FAILED}))
        return &r;
    }
    return nullptr;
  }
  [[nodiscard]] const Reply* with_status(std::int64_t id, std::int8_t status) const {
    for (const auto& r : replies) {
      if (r.command_id == id && r.status == status) return &r;
    }
    return nullptr;
  }
};

class LibmodbusPeer : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() / ("adam-libmodbus-" + std::to_string(::getpid()) + "-" +
                                                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override {
    stop_ = true;
    if (peer_.joinable()) peer_.join();
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  void load(int drives) {
    auto loaded = config::load_string(yaml_for(dir_, drives));
    ASSERT_TRUE(loaded.ok()) << loaded.error_text();
    config_ = *loaded.config;
  }
  bool pump_until(const std::function<bool()>& done, Duration timeout) {
    const auto end = SteadyClock::now() + timeout;
    while (!done()) {
      if (SteadyClock::now() > end) return false;
      loop_.run_once(5ms);
    }
    return true;
  }
  // Runs `body` on the peer thread while this thread pumps the loop; joined before returning.
  bool run_peer(std::function<void()> body, Duration timeout) {
    std::atomic<bool> finished{false};
    peer_ = std::thread([&finished, body = std::move(body)] {
      body();
      finished = true;
    });
    const bool ok = pump_until([&] { return finished.load(); }, timeout);
    stop_ = true;  // a peer loop that watches stop_ ends; a blocked libmodbus call ends by its timeout
    while (!finished) loop_.run_once(5ms);
    peer_.join();
    return ok;
  }

  std::filesystem::path dir_;
  config::Config config_;
  EventLoop loop_;
  std::thread peer_;
  std::atomic<bool> stop_{false};
};

// ---- libmodbus client → our simulated drives ---------------------------------------------------

struct Call {
  int rc = 0;
  int error = 0;
};

TEST_F(LibmodbusPeer, ClientReadsWritesAndGetsExceptionsFromSimulatedDrive) {
  load(2);
  std::vector<motionlcm::sim_report_t> reports;
  std::error_code error;
  auto host = sim::open_adam_line(
      loop_, config_, config_.buses[0], [&](const motionlcm::sim_report_t& r) { reports.push_back(r); }, error);
  ASSERT_TRUE(host) << error.message();

  struct {
    Call connect, version, subdivision, accel_write, accel_read, speed_write, speed_read, preset, position;
    Call hole, input_registers, bad_value;
    std::uint16_t version_regs[2]{}, subdivision_regs[2]{}, accel{}, speed_regs[2]{}, position_regs[2]{};
  } r;
  const std::string path = host->link_path();
  const auto record = [](Call& call, int rc) {
    call.rc = rc;
    call.error = rc == -1 ? errno : 0;
  };
  ASSERT_TRUE(run_peer(
      [&] {
        modbus_t* ctx = modbus_new_rtu(path.c_str(), 115200, 'N', 8, 1);
        if (ctx == nullptr) return;
        modbus_set_response_timeout(ctx, 1, 0);
        modbus_set_slave(ctx, 1);
        record(r.connect, modbus_connect(ctx));
        if (r.connect.rc == 0) {
          record(r.version, modbus_read_registers(ctx, 0x0000, 2, r.version_regs));
          record(r.subdivision, modbus_read_registers(ctx, 0x0024, 2, r.subdivision_regs));
          // FC 0x06 of a 16-bit setting, read back.
          record(r.accel_write, modbus_write_register(ctx, 0x0098, 250));
          record(r.accel_read, modbus_read_registers(ctx, 0x0098, 1, &r.accel));
          // FC 0x10 of a 32-bit setting, low word first: 123456 = 0x0001E240 → E240 0001.
          std::uint16_t speed[2]{};
          put_low_word_first(speed, 123456);
          record(r.speed_write, modbus_write_registers(ctx, 0x00D8, 2, speed));
          record(r.speed_read, modbus_read_registers(ctx, 0x00D8, 2, r.speed_regs));
          // A negative 32-bit value: preset the position counter (0x00D2), read it at 0x0004.
          std::uint16_t preset[2]{};
          put_low_word_first(preset, -12345);
          record(r.preset, modbus_write_registers(ctx, 0x00D2, 2, preset));
          record(r.position, modbus_read_registers(ctx, 0x0004, 2, r.position_regs));
          // Exceptions: 0x0014 is a hole of the register map (0x02); FC 0x04 is not a function of
          // the drive (0x01); a table size of 0 is outside 1…2048 (0x03, §8.54).
          std::uint16_t scratch[4]{};
          record(r.hole, modbus_read_registers(ctx, 0x0014, 1, scratch));
          record(r.input_registers, modbus_read_input_registers(ctx, 0x0004, 2, scratch));
          record(r.bad_value, modbus_write_register(ctx, 0x00AA, 0));
        }
        modbus_close(ctx);
        modbus_free(ctx);
      },
      30s));

  ASSERT_EQ(r.connect.rc, 0) << modbus_strerror(r.connect.error);
  ASSERT_EQ(r.version.rc, 2) << modbus_strerror(r.version.error);
  EXPECT_EQ(r.version_regs[0], 0x3731);  // "170" (§8.1)
  EXPECT_EQ(r.version_regs[1], 0x0030);
  ASSERT_EQ(r.subdivision.rc, 2) << modbus_strerror(r.subdivision.error);
  EXPECT_EQ(r.subdivision_regs[0], 4000);  // §8.29: 4000 pulses/rev as 0F A0 00 00
  EXPECT_EQ(r.subdivision_regs[1], 0);
  EXPECT_EQ(low_word_first(r.subdivision_regs), 4000);
  EXPECT_EQ(r.accel_write.rc, 1) << modbus_strerror(r.accel_write.error);
  ASSERT_EQ(r.accel_read.rc, 1) << modbus_strerror(r.accel_read.error);
  EXPECT_EQ(r.accel, 250);
  EXPECT_EQ(r.speed_write.rc, 2) << modbus_strerror(r.speed_write.error);
  ASSERT_EQ(r.speed_read.rc, 2) << modbus_strerror(r.speed_read.error);
  EXPECT_EQ(r.speed_regs[0], 0xE240);
  EXPECT_EQ(r.speed_regs[1], 0x0001);
  EXPECT_EQ(low_word_first(r.speed_regs), 123456);
  EXPECT_EQ(r.preset.rc, 2) << modbus_strerror(r.preset.error);
  ASSERT_EQ(r.position.rc, 2) << modbus_strerror(r.position.error);
  EXPECT_EQ(r.position_regs[0], 0xCFC7);  // -12345 = 0xFFFFCFC7, low word first
  EXPECT_EQ(r.position_regs[1], 0xFFFF);
  EXPECT_EQ(low_word_first(r.position_regs), -12345);
  EXPECT_EQ(r.hole.rc, -1);
  EXPECT_EQ(r.hole.error, EMBXILADD) << modbus_strerror(r.hole.error);
  EXPECT_EQ(r.input_registers.rc, -1);
  EXPECT_EQ(r.input_registers.error, EMBXILFUN) << modbus_strerror(r.input_registers.error);
  EXPECT_EQ(r.bad_value.rc, -1);
  EXPECT_EQ(r.bad_value.error, EMBXILVAL) << modbus_strerror(r.bad_value.error);
  // Nothing above moves a drive: the preset only sets the counter (§8.66).
  for (const auto& report : reports) EXPECT_NE(report.kind, std::int8_t{motionlcm::sim_report_t::MOTION_STARTED});
}

TEST_F(LibmodbusPeer, ClientBroadcastTableExecuteStartsBothDrivesWithoutReply) {
  load(2);
  std::vector<motionlcm::sim_report_t> reports;
  std::error_code error;
  auto host = sim::open_adam_line(
      loop_, config_, config_.buses[0], [&](const motionlcm::sim_report_t& r) { reports.push_back(r); }, error);
  ASSERT_TRUE(host) << error.message();

  struct {
    Call connect, preload[2][4], broadcast, after[2];
    std::chrono::microseconds broadcast_took{};
    std::uint16_t table_size[2]{};
  } r;
  const std::string path = host->link_path();
  const std::int32_t targets[2] = {3000, -2000};
  const auto record = [](Call& call, int rc) {
    call.rc = rc;
    call.error = rc == -1 ? errno : 0;
  };
  ASSERT_TRUE(run_peer(
      [&] {
        modbus_t* ctx = modbus_new_rtu(path.c_str(), 115200, 'N', 8, 1);
        if (ctx == nullptr) return;
        modbus_set_response_timeout(ctx, 1, 0);
        record(r.connect, modbus_connect(ctx));
        if (r.connect.rc != 0) {
          modbus_free(ctx);
          return;
        }
        // Preload each drive (table data, §8.54): table entry 0 at register 300 + 200 = 500 (INT32,
        // low word first), table size 1, pointer 0, start offset 200.
        for (int i = 0; i < 2; ++i) {
          modbus_set_slave(ctx, i + 1);
          std::uint16_t entry[2]{};
          put_low_word_first(entry, targets[i]);
          record(r.preload[i][0], modbus_write_registers(ctx, 500, 2, entry));
          record(r.preload[i][1], modbus_write_register(ctx, 0x00AA, 1));
          record(r.preload[i][2], modbus_write_register(ctx, 0x00AB, 0));
          record(r.preload[i][3], modbus_write_register(ctx, 0x00AC, 200));
        }
        // The broadcast: 00 06 00 DD 00 00 (CRC). Nobody answers (§5); libmodbus 3.1.6 still waits
        // for a confirmation and reports ETIMEDOUT after the response timeout (later releases
        // return at once): either way no byte came back.
        modbus_set_slave(ctx, MODBUS_BROADCAST_ADDRESS);
        modbus_set_response_timeout(ctx, 0, 300000);
        const auto before = std::chrono::steady_clock::now();
        record(r.broadcast, modbus_write_register(ctx, 0x00DD, 0));
        r.broadcast_took =
            std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - before);
        // The line is clean afterwards: unicast reads of both drives match their requests.
        modbus_set_response_timeout(ctx, 1, 0);
        for (int i = 0; i < 2; ++i) {
          modbus_set_slave(ctx, i + 1);
          record(r.after[i], modbus_read_registers(ctx, 0x00AA, 1, &r.table_size[i]));
        }
        modbus_close(ctx);
        modbus_free(ctx);
      },
      30s));

  ASSERT_EQ(r.connect.rc, 0) << modbus_strerror(r.connect.error);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(r.preload[i][0].rc, 2) << modbus_strerror(r.preload[i][0].error);
    for (int k = 1; k < 4; ++k) EXPECT_EQ(r.preload[i][k].rc, 1) << k << ": " << modbus_strerror(r.preload[i][k].error);
    ASSERT_EQ(r.after[i].rc, 1) << modbus_strerror(r.after[i].error);
    EXPECT_EQ(r.table_size[i], 1);
  }
  // Either libmodbus did not wait (rc 1) or it waited the whole 300 ms and heard nothing.
  std::printf("[ libmodbus %s ] broadcast write: rc %d (%s) after %lld us\n", LIBMODBUS_VERSION_STRING, r.broadcast.rc,
              r.broadcast.rc == -1 ? modbus_strerror(r.broadcast.error) : "no wait",
              static_cast<long long>(r.broadcast_took.count()));
  if (r.broadcast.rc == -1) {
    EXPECT_EQ(r.broadcast.error, ETIMEDOUT) << modbus_strerror(r.broadcast.error);
    EXPECT_GE(r.broadcast_took, 290ms);
  } else {
    EXPECT_EQ(r.broadcast.rc, 1);
  }
  std::vector<motionlcm::sim_report_t> starts;
  for (const auto& report : reports) {
    if (report.kind == std::int8_t{motionlcm::sim_report_t::MOTION_STARTED}) starts.push_back(report);
  }
  ASSERT_EQ(starts.size(), 2U) << "the broadcast did not start both drives";
  EXPECT_EQ(starts[0].frame_utime, starts[1].frame_utime) << "the two drives did not start on the same frame";
  for (const auto& s : starts) EXPECT_EQ(s.target_counts, s.drive == "c-drive" ? targets[0] : targets[1]) << s.drive;
}

// ---- our master → libmodbus server -------------------------------------------------------------

// A libmodbus RTU server for slave 1 on `path`, with a minimal drive behind the mapping: a write of
// 0x00DD (table execute, unicast or broadcast) "moves" at once to the table entry at the pointer.
class LibmodbusServer {
 public:
  struct Seen {
    int slave = 0;
    int function = 0;
    int address = 0;
  };

  LibmodbusServer() : mapping_(modbus_mapping_new(0, 0, kRegisters, 0)) {
    put_low_word_first(&mapping_->tab_registers[0x0024], 4000);     // subdivision
    put_low_word_first(&mapping_->tab_registers[0x0004], -100000);  // position
    mapping_->tab_registers[0x0006] = 0x1000;                       // status: X12 in position, idle
  }
  ~LibmodbusServer() {
    stop();
    modbus_mapping_free(mapping_);
  }
  LibmodbusServer(const LibmodbusServer&) = delete;
  LibmodbusServer& operator=(const LibmodbusServer&) = delete;

  void start(const std::string& path) {
    thread_ = std::thread([this, path] { serve(path); });
  }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  [[nodiscard]] bool serving() const { return serving_; }
  [[nodiscard]] std::string failure() const {
    std::lock_guard lock(mutex_);
    return failure_;
  }
  template <class F>
  auto with_registers(F&& f) {
    std::lock_guard lock(mutex_);
    return f(mapping_->tab_registers);
  }
  [[nodiscard]] std::vector<Seen> seen() const {
    std::lock_guard lock(mutex_);
    return seen_;
  }

  static constexpr int kRegisters = 0x0300;  // the table at 500 fits; 0x0300 and up are refused

 private:
  void serve(const std::string& path) {
    modbus_t* ctx = modbus_new_rtu(path.c_str(), 115200, 'N', 8, 1);
    if (ctx == nullptr || modbus_set_slave(ctx, 1) != 0 || modbus_connect(ctx) != 0) {
      std::lock_guard lock(mutex_);
      failure_ = std::string("libmodbus server cannot open ") + path + ": " + modbus_strerror(errno);
      if (ctx != nullptr) modbus_free(ctx);
      return;
    }
    modbus_set_indication_timeout(ctx, 0, 50000);  // so that stop_ is noticed
    serving_ = true;
    std::vector<std::uint8_t> request(MODBUS_RTU_MAX_ADU_LENGTH);
    while (!stop_) {
      const int n = modbus_receive(ctx, request.data());
      if (n <= 0) continue;  // -1: timeout or bad frame; 0: another slave's request
      std::lock_guard lock(mutex_);
      const int function = request[1];
      const int address = (request[2] << 8) | request[3];
      seen_.push_back({request[0], function, address});
      modbus_reply(ctx, request.data(), n, mapping_);  // no reply to a broadcast (libmodbus, RTU)
      const bool wrote_execute = (function == MODBUS_FC_WRITE_SINGLE_REGISTER && address == 0x00DD) ||
                                 (function == MODBUS_FC_WRITE_MULTIPLE_REGISTERS && address <= 0x00DD &&
                                  address + ((request[4] << 8) | request[5]) > 0x00DD);
      if (wrote_execute) execute_table_entry();
    }
    modbus_close(ctx);
    modbus_free(ctx);
  }
  void execute_table_entry() {
    std::uint16_t* regs = mapping_->tab_registers;
    const int at = 300 + regs[0x00AC] + 2 * regs[0x00AB];
    if (at + 1 >= kRegisters) return;
    regs[0x0004] = regs[at];
    regs[0x0005] = regs[at + 1];
    regs[0x0006] = 0x1000;
  }

  modbus_mapping_t* mapping_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::atomic<bool> serving_{false};
  mutable std::mutex mutex_;
  std::vector<Seen> seen_;
  std::string failure_;
};

class LibmodbusServerPeer : public LibmodbusPeer {
 protected:
  void SetUp() override {
    LibmodbusPeer::SetUp();
    load(1);
    // Null modem: our master opens link A, libmodbus opens link B, the loop copies between masters.
    std::error_code error;
    a_ = serial::PtyLink::create((dir_ / "master.tty").string(), line_, error);
    ASSERT_TRUE(a_) << error.message();
    b_ = serial::PtyLink::create((dir_ / "server.tty").string(), line_, error);
    ASSERT_TRUE(b_) << error.message();
    loop_.watch(a_->master_fd(), [this] { bridge(a_->master_fd(), b_->master_fd()); });
    loop_.watch(b_->master_fd(), [this] { bridge(b_->master_fd(), a_->master_fd()); });
    server_.start(b_->link_path());
    ASSERT_TRUE(pump_until([&] { return server_.serving() || !server_.failure().empty(); }, 5s));
    ASSERT_TRUE(server_.serving()) << server_.failure();
  }
  void TearDown() override {
    server_.stop();  // joined before the ptys and the loop go
    if (a_) loop_.unwatch(a_->master_fd());
    if (b_) loop_.unwatch(b_->master_fd());
    LibmodbusPeer::TearDown();
  }
  static void bridge(int from, int to) {
    std::array<std::uint8_t, 512> buffer{};
    ssize_t n = 0;
    while ((n = ::read(from, buffer.data(), buffer.size())) > 0) {
      if (::write(to, buffer.data(), static_cast<std::size_t>(n)) != n) break;
    }
  }
  Command command(std::int64_t id, std::int8_t kind) const {
    Command c{};
    c.command_id = id;
    c.kind = kind;
    c.axes.push_back(motionlcm::axis_command_t{});
    c.axes[0].axis = "c";
    c.num_axes = 1;
    return c;
  }

  const serial::SerialSettings line_{};
  std::unique_ptr<serial::PtyLink> a_, b_;
  LibmodbusServer server_;
};

TEST_F(LibmodbusServerPeer, MasterSetsUpPollsAndWritesAgainstLibmodbus) {
  Recorder out;
  adam_driver::AdamBusDriver driver(loop_, adam_driver::settings_from_config(config_, config_.buses[0]),
                                    a_->link_path(), line_, out);
  driver.start();
  ASSERT_TRUE(pump_until([&] { return driver.ready(); }, 10s)) << "our master never finished set-up against libmodbus";
  // Status polling decoded the negative 32-bit position low word first.
  ASSERT_TRUE(pump_until([&] { return !out.statuses.empty() && out.statuses.back().sample_utime != 0; }, 5s));
  EXPECT_EQ(out.statuses.back().position_counts, -100000);
  EXPECT_TRUE(out.statuses.back().online);
  EXPECT_TRUE(out.statuses.back().in_position);
  EXPECT_FALSE(out.statuses.back().moving);

  // 32-bit write (FC 0x10, low word first in libmodbus's mapping), then read back by our master.
  auto write = command(1, std::int8_t{Command::PARAM_WRITE});
  write.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  write.param.index = 0x00D8;
  write.param.value = 123456;
  driver.execute(write);
  ASSERT_TRUE(pump_until([&] { return out.terminal(1) != nullptr; }, 5s));
  EXPECT_EQ(out.terminal(1)->status, std::int8_t{Reply::DONE}) << out.terminal(1)->reason;
  EXPECT_EQ(server_.with_registers([](const std::uint16_t* r) { return r[0x00D8]; }), 0xE240);
  EXPECT_EQ(server_.with_registers([](const std::uint16_t* r) { return r[0x00D9]; }), 0x0001);

  server_.with_registers([](std::uint16_t* r) {
    r[0x0098] = 321;
    return 0;
  });
  auto read16 = command(2, std::int8_t{Command::PARAM_READ});
  read16.param.space = std::int8_t{motionlcm::param_t::MODBUS_REGISTER};
  read16.param.index = 0x0098;
  driver.execute(read16);
  auto read32 = write;
  read32.command_id = 3;
  read32.kind = std::int8_t{Command::PARAM_READ};
  read32.param.value = 0;
  driver.execute(read32);
  ASSERT_TRUE(pump_until([&] { return out.terminal(2) != nullptr && out.terminal(3) != nullptr; }, 5s));
  ASSERT_EQ(out.terminal(2)->status, std::int8_t{Reply::DONE}) << out.terminal(2)->reason;
  EXPECT_EQ(out.terminal(2)->param.value, 321);
  ASSERT_EQ(out.terminal(3)->status, std::int8_t{Reply::DONE}) << out.terminal(3)->reason;
  EXPECT_EQ(out.terminal(3)->param.value, 123456);

  // libmodbus refuses a register outside its mapping with exception 0x02: the command fails at
  // once (no retry), naming the drive and the register, and an ERROR_REPORT event says why.
  auto outside = read16;
  outside.command_id = 4;
  outside.param.index = 0x0400;
  outside.param.width = 1;
  driver.execute(outside);
  ASSERT_TRUE(pump_until([&] { return out.terminal(4) != nullptr; }, 5s));
  EXPECT_EQ(out.terminal(4)->status, std::int8_t{Reply::FAILED});
  EXPECT_NE(out.terminal(4)->reason.find("Modbus exception 2"), std::string::npos) << out.terminal(4)->reason;
  EXPECT_NE(out.terminal(4)->reason.find("c-drive (slave 1)"), std::string::npos) << out.terminal(4)->reason;
  EXPECT_NE(out.terminal(4)->reason.find("0x0400"), std::string::npos) << out.terminal(4)->reason;
  EXPECT_TRUE(std::any_of(out.events.begin(), out.events.end(), [](const gateway::DriveEvent& e) {
    return e.kind == std::int16_t{motionlcm::event_t::ERROR_REPORT} && e.code == 2;
  }));
  const auto seen = server_.seen();
  EXPECT_EQ(std::count_if(seen.begin(), seen.end(), [](const auto& s) { return s.address == 0x0400; }), 1)
      << "an exception reply must not be retried";
  const auto stats = driver.statistics().at(0);
  EXPECT_EQ(stats.errors, 0);
  EXPECT_EQ(stats.timeouts, 0);
}

TEST_F(LibmodbusServerPeer, MasterBroadcastStartIsExecutedByLibmodbusWithoutReply) {
  Recorder out;
  adam_driver::AdamBusDriver driver(loop_, adam_driver::settings_from_config(config_, config_.buses[0]),
                                    a_->link_path(), line_, out);
  driver.start();
  ASSERT_TRUE(pump_until([&] { return driver.ready(); }, 10s)) << "our master never finished set-up against libmodbus";

  auto move = command(7, std::int8_t{Command::ARM_MOVE});
  move.trigger_id = 0;  // start as soon as armed
  move.axes[0].target_counts = -98000;
  move.axes[0].velocity = 8000;
  move.axes[0].acceleration = 40000;
  move.axes[0].deceleration = 40000;
  driver.execute(move);
  ASSERT_TRUE(pump_until([&] { return out.terminal(7) != nullptr; }, 10s));
  ASSERT_EQ(out.terminal(7)->status, std::int8_t{Reply::DONE}) << out.terminal(7)->reason;
  const Reply* started = out.with_status(7, std::int8_t{Reply::STARTED});
  ASSERT_NE(started, nullptr);
  EXPECT_EQ(started->start_mechanism, "broadcast");
  EXPECT_NE(out.with_status(7, std::int8_t{Reply::ARMED}), nullptr);

  // libmodbus saw the preload as unicast and the start as ONE broadcast FC 0x06 of 0x00DD.
  const auto seen = server_.seen();
  const auto executes = std::count_if(seen.begin(), seen.end(), [](const auto& s) { return s.address == 0x00DD; });
  EXPECT_EQ(executes, 1);
  const auto broadcast = std::find_if(seen.begin(), seen.end(), [](const auto& s) { return s.slave == 0; });
  ASSERT_NE(broadcast, seen.end());
  EXPECT_EQ(broadcast->function, MODBUS_FC_WRITE_SINGLE_REGISTER);
  EXPECT_EQ(broadcast->address, 0x00DD);
  for (const auto& s : seen) {
    if (&s != &*broadcast) { EXPECT_EQ(s.slave, 1) << "function " << s.function << " at " << s.address; }
  }
  // The table entry libmodbus holds: -98000 low word first at 500/501, size 1, pointer 0, offset 200.
  EXPECT_EQ(server_.with_registers([](const std::uint16_t* r) { return low_word_first(&r[500]); }), -98000);
  EXPECT_EQ(server_.with_registers([](const std::uint16_t* r) { return r[0x00AC]; }), 200);
  // No reply to the broadcast reached our master (it would be an unsolicited frame, an error).
  ASSERT_TRUE(pump_until([&] { return !out.statuses.empty() && out.statuses.back().position_counts == -98000; }, 5s));
  const auto stats = driver.statistics().at(0);
  EXPECT_EQ(stats.errors, 0);
  EXPECT_EQ(stats.timeouts, 0);
  // Every frame but the broadcast is answered (one poll may be on the line right now).
  EXPECT_GE(stats.tx_frames - stats.rx_frames, 1);
  EXPECT_LE(stats.tx_frames - stats.rx_frames, 2);
}

}  // namespace
}  // namespace motion
