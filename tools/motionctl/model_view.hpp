// `motionctl status --model`: the drive models the gateways publish (DRIVE_MODEL), as text and
// as JSON (model_view.cpp).
#pragma once

#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include <motionlcm/drive_model_t.hpp>

#include "motion/config/config.hpp"

namespace motion::ctl {

// Each axis of `c` with its model, or a line saying none was heard.
void print_models(const config::Config& c, const std::map<std::string, motionlcm::drive_model_t>& models);
// The models heard, keyed by axis.
nlohmann::json models_json(const std::map<std::string, motionlcm::drive_model_t>& models);

}  // namespace motion::ctl
