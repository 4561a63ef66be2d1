// Internal: the power-up parameters a configured UIM342 holds (see uim342_setup.cpp).
// Thread contract: pure function.
#pragma once

#include "motion/config/config.hpp"
#include "motion/sim/uim342_drive.hpp"

namespace motion::sim {

[[nodiscard]] Uim342Drive::Parameters setup_parameters(const config::Drive& drive, const Uim342Identity& identity);

}  // namespace motion::sim
