// The drive model end to end (configs/uc57-resolution.yaml): a simulated UC57 whose 2006h says
// 3200 pulses/rev while the configuration implies the factory 10000. The gateway reads 2006h back
// at set-up (UC57 manual §5.1) and publishes it in DRIVE_MODEL; the coordinator plans from that
// model only, so a move ends at its target count and takes the time the coordinator predicted
// (with the assumed 10000 the stack's whole-rpm speeds would differ from the planned ones).
#include <gtest/gtest.h>

#include <csignal>
#include <cstdio>
#include <optional>

#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/event_t.hpp>
#include <motionlcm/gateway_command_t.hpp>
#include <motionlcm/param_t.hpp>

#include "sim_lab.hpp"

namespace motion::testing {
namespace {

using motionlcm::drive_model_t;

// 2006h subdivision code of 3200 pulses/rev (UC57 manual §5.1 table: 200, 400, 800, 1600, 3200, ...).
constexpr std::int64_t kCode3200 = 4;

// A PARAM_WRITE of 2006h to subdivision `code` for axis a.
request_t write_resolution(std::int64_t code) {
  request_t write = Client::make(request_t::PARAM_WRITE, std::vector<std::string>{"a"});
  write.param.space = motionlcm::param_t::CANOPEN_OBJECT;
  write.param.index = 0x2006;
  write.param.subindex = 0;
  write.param.width = 2;
  write.param.value = code;
  return write;
}

// The simulated drive's MOTION_FINISHED reports of a-drive.
std::vector<motionlcm::sim_report_t> finishes(const SimLab& lab) {
  std::vector<motionlcm::sim_report_t> out;
  for (const auto& r : lab.reports()) {
    if (r.drive == "a-drive" && r.kind == motionlcm::sim_report_t::MOTION_FINISHED) out.push_back(r);
  }
  return out;
}

TEST(Uc57Model, DriveResolutionReadBackDrivesThePlanAndTheMoveLandsOnTime) {
  SimLab lab(source_path("tests/integration/configs/uc57-resolution.yaml"));
  std::optional<drive_model_t> model;
  lab.group().node().subscribe<drive_model_t>(lcm::channels::kDriveModel,
                                              [&](const drive_model_t& m, const std::string&) {
                                                if (m.axis == "a") model = m;
                                              });
  std::vector<event_t> events;
  lab.client().on_event([&](const event_t& e) { events.push_back(e); });
  ASSERT_TRUE(lab.start({"a"}));
  ASSERT_TRUE(lab.client().wait_until([&] { return model.has_value(); }, seconds(10))) << "no DRIVE_MODEL for a";
  EXPECT_EQ(model->counts_per_revolution, 10000);
  EXPECT_EQ(model->resolution_source, std::int8_t{drive_model_t::RESOLUTION_READ_BACK});

  // The drive is set to 3200 pulses/rev behind the gateway's back; a new gateway reads it.
  const auto written = lab.call(write_resolution(kCode3200));
  ASSERT_EQ(written.status, st(reply_t::DONE)) << written.reason;
  const auto gateway = lab.group().heartbeat("gateway:can0");
  ASSERT_TRUE(gateway.has_value());
  ASSERT_EQ(::kill(static_cast<pid_t>(gateway->pid), SIGKILL), 0);
  lab.group().stop(static_cast<pid_t>(gateway->pid));  // reap it
  model.reset();
  ASSERT_GT(lab.start_gateway("can0"), 0);
  ASSERT_TRUE(lab.client().wait_until([&] { return model.has_value(); }, seconds(15)))
      << "no DRIVE_MODEL from the new gateway";
  EXPECT_EQ(model->counts_per_revolution, 3200);
  EXPECT_EQ(model->assumed_counts_per_revolution, 10000);
  EXPECT_EQ(model->resolution_source, std::int8_t{drive_model_t::RESOLUTION_READ_BACK});
  EXPECT_DOUBLE_EQ(model->velocity_step, 3200 / 60.0);
  ASSERT_TRUE(lab.client().wait_until(
      [&] {
        return std::any_of(events.begin(), events.end(), [](const event_t& e) {
          return e.axis == "a" && e.kind == ev(event_t::CONFIG_MISMATCH) &&
                 e.text.find("3200 counts/rev") != std::string::npos;
        });
      },
      seconds(5)))
      << "no CONFIG_MISMATCH event saying the drive works at 3200 counts/rev";
  // motionctl status --model asks the gateways and prints what they say.
  std::string printed;
  ASSERT_EQ(lab.group().run_to_completion(
                {"status-model", "motionctl", {"--config", lab.config_path(), "status", "--model"}, {}}, &printed,
                seconds(20)),
            0)
      << printed;
  EXPECT_NE(printed.find("resolution  3200 counts/rev (configuration implies 10000), read back"), std::string::npos)
      << printed;
  EXPECT_NE(printed.find("start       SYNC (address 128)"), std::string::npos) << printed;
  // With the model, the axis's arming time (ARM_TIMING) per bus: a UC57 arms in a few frames.
  EXPECT_NE(printed.find("arming on can0 (ARM_TIMING: line time of the frames arming sends; 1 drive on the bus)\n"
                         "  a           0.0 us loading its move, 0.0 us readying each other drive\n"
                         "  bus         0.0 us every axis armed together, at most 0.0 us one axis armed alone"),
            std::string::npos)
      << printed;
  ASSERT_TRUE(lab.client().wait_until([&] { return lab.client().axes().at("a").online; }, seconds(15)));
  const auto enabled = lab.call(Client::make(request_t::ENABLE, std::vector<std::string>{"a"}));
  ASSERT_EQ(enabled.status, st(reply_t::DONE)) << enabled.reason;

  // 90 degrees = 2500 counts, at half speed: 180 deg/s = 5000 counts/s, 1.5 rpm steps of 3200/60.
  lab.clear_reports();
  request_t move = Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 90.0}});
  move.velocity_scale = 0.5;
  const auto done = lab.call(move);
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !lab.client().axes().at("a").moving; }, seconds(5)));
  EXPECT_EQ(lab.client().axes().at("a").position_counts, 2500);
  ASSERT_TRUE(lab.client().wait_until(
      [&] {
        return std::any_of(lab.reports().begin(), lab.reports().end(), [](const motionlcm::sim_report_t& r) {
          return r.kind == motionlcm::sim_report_t::MOTION_FINISHED;
        });
      },
      seconds(5)));
  const motionlcm::sim_report_t* started = nullptr;
  const motionlcm::sim_report_t* finished = nullptr;
  for (const auto& r : lab.reports()) {
    if (r.drive != "a-drive") continue;
    if (r.kind == motionlcm::sim_report_t::MOTION_STARTED && started == nullptr) started = &r;
    if (r.kind == motionlcm::sim_report_t::MOTION_FINISHED) finished = &r;
  }
  ASSERT_NE(started, nullptr);
  ASSERT_NE(finished, nullptr);
  EXPECT_EQ(started->target_counts, 2500);
  EXPECT_EQ(finished->position_counts, 2500);
  // The simulated drive's own start and finish: the duration the coordinator predicted, early by
  // at most the start-speed jump the trapezoid model ignores (200Eh 10 rpm = 533 counts/s here,
  // quantizer.hpp: tens of ms on this move), never late.
  const double measured_s = static_cast<double>(finished->frame_utime - started->frame_utime) / 1e6;
  std::printf("90 degrees at 3200 counts/rev: predicted %.4f s, measured %.4f s (simulated drive)\n",
              done.predicted_duration_s, measured_s);
  ASSERT_GT(done.predicted_duration_s, 0.3);
  EXPECT_LE(measured_s, done.predicted_duration_s + 0.01)
      << "measured " << measured_s << " s, predicted " << done.predicted_duration_s << " s";
  EXPECT_GE(measured_s, done.predicted_duration_s - 0.05)
      << "measured " << measured_s << " s, predicted " << done.predicted_duration_s << " s";
}

// A PARAM_WRITE of 2006h through the gateway changes the drive's resolution while the gateway runs:
// the gateway reads 2006h (and 200Eh) back and republishes the axis's model at once, and the next
// move is planned at the new resolution. A write of 2006h while the axis moves is refused.
TEST(Uc57Model, ParamWriteOfTheResolutionRepublishesTheModel) {
  SimLab lab(source_path("tests/integration/configs/uc57-resolution.yaml"));
  std::vector<drive_model_t> models;
  lab.group().node().subscribe<drive_model_t>(lcm::channels::kDriveModel,
                                              [&](const drive_model_t& m, const std::string&) {
                                                if (m.axis == "a") models.push_back(m);
                                              });
  ASSERT_TRUE(lab.start({"a"}));
  ASSERT_TRUE(lab.client().wait_until([&] { return !models.empty(); }, seconds(10))) << "no DRIVE_MODEL for a";
  EXPECT_EQ(models.back().counts_per_revolution, 10000);
  ASSERT_TRUE(lab.enable({"a"}));

  const auto written = lab.call(write_resolution(kCode3200));
  ASSERT_EQ(written.status, st(reply_t::DONE)) << written.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return models.back().counts_per_revolution == 3200; }, seconds(5)))
      << "no DRIVE_MODEL with 3200 counts/rev after the write of 2006h (last: " << models.back().counts_per_revolution
      << ")";
  EXPECT_EQ(models.back().resolution_source, std::int8_t{drive_model_t::RESOLUTION_READ_BACK});
  EXPECT_DOUBLE_EQ(models.back().velocity_step, 3200 / 60.0);
  EXPECT_GT(models.back().utime, models.front().utime);

  // 90 degrees = 2500 counts, planned at 3200 counts/rev: the drive's own start and finish take
  // the duration the coordinator predicted (at 10000 the stack's whole-rpm speeds would differ).
  lab.clear_reports();
  request_t move = Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 90.0}});
  move.velocity_scale = 0.5;
  const auto done = lab.call(move);
  ASSERT_EQ(done.status, st(reply_t::DONE)) << done.reason;
  ASSERT_TRUE(lab.client().wait_until([&] { return !finishes(lab).empty(); }, seconds(5)));
  EXPECT_EQ(finishes(lab).back().position_counts, 2500);
  const auto starts = lab.starts_of("a-drive");
  ASSERT_FALSE(starts.empty());
  const double measured_s = static_cast<double>(finishes(lab).back().frame_utime - starts.front().frame_utime) / 1e6;
  std::printf("90 degrees after 2006h was written to 3200 counts/rev: predicted %.4f s, measured %.4f s\n",
              done.predicted_duration_s, measured_s);
  EXPECT_LE(measured_s, done.predicted_duration_s + 0.01);
  EXPECT_GE(measured_s, done.predicted_duration_s - 0.05);

  // A write of 2006h straight to the gateway while the axis moves (the coordinator refuses one for
  // a busy axis itself; another sender is refused by the gateway) fails and changes nothing.
  lab.client().send(Client::make(request_t::MOVE_ABSOLUTE, Values{{"a", 700.0}}));
  ASSERT_TRUE(lab.client().wait_until([&] { return lab.state("a").moving; }, seconds(5)));
  motionlcm::gateway_command_t direct{};
  direct.utime = wall_time_us();
  direct.bus = "can0";
  direct.command_id = 77001;
  direct.kind = motionlcm::gateway_command_t::PARAM_WRITE;
  direct.num_axes = 1;
  direct.axes.resize(1);
  direct.axes[0].axis = "a";
  direct.param = write_resolution(kCode3200 + 1).param;
  const std::size_t models_before = models.size();
  lab.group().node().publish(lcm::channels::gateway_command("can0"), direct);
  const motionlcm::gateway_reply_t* refused = nullptr;
  ASSERT_TRUE(lab.client().wait_until(
      [&] {
        for (const auto& r : lab.gateway_replies())
          if (r.command_id == 77001 && r.status == motionlcm::gateway_reply_t::FAILED) refused = &r;
        return refused != nullptr;
      },
      seconds(5)));
  EXPECT_EQ(refused->error_code, code(ReplyError::kAxisBusy));
  EXPECT_NE(refused->reason.find("2006h (resolution) cannot be written while the axis is moving"), std::string::npos)
      << refused->reason;
  const auto stopped = lab.call(Client::make(request_t::STOP, std::vector<std::string>{"a"}));
  EXPECT_EQ(stopped.status, st(reply_t::DONE)) << stopped.reason;
  lab.pause(milliseconds(300));
  EXPECT_EQ(models.size(), models_before) << "a refused write republished the model";
  EXPECT_EQ(models.back().counts_per_revolution, 3200);
}

}  // namespace
}  // namespace motion::testing
