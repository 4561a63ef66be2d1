// `motionctl status --model`: the drive models the gateways publish (DRIVE_MODEL) and, with each,
// the line time of arming the axis (ARM_TIMING), and per bus the start wait (LINE_TIMING), as text
// and as JSON (model_view.cpp).
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include <motionlcm/arm_timing_t.hpp>
#include <motionlcm/drive_model_t.hpp>
#include <motionlcm/line_timing_t.hpp>

#include "motion/config/config.hpp"

namespace motion::ctl {

// What the gateways published, by axis.
struct HeardModels {
  std::map<std::string, motionlcm::drive_model_t> models;
  std::map<std::string, motionlcm::arm_timing_t> arming;
  std::map<std::string, motionlcm::line_timing_t> lines;  // by bus
};

// Each axis of `c` with its model (or a line saying none was heard), then per bus the line time of
// arming its axes: each axis's own and, for a bus, the sums the coordinator adds to its arming
// deadline when every axis of the bus is armed together and at most when one axis is armed alone,
// and the bus's start wait.
void print_models(const config::Config& c, const HeardModels& heard);
// The models heard, keyed by axis; each with its arm_timing (null when none was heard): its own
// figures and its bus's sums; and its bus's start_wait_us (null when no LINE_TIMING was heard).
nlohmann::json models_json(const config::Config& c, const HeardModels& heard);

}  // namespace motion::ctl
