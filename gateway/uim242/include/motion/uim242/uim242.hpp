// motion::uim242 — the UIROBOT UIM242 string protocol through a UIM2501/2502 RS232-CAN gateway
// (manuals: UIM242XX user manual EN and CN Ver.1301/1302). Pure codec, no I/O, no clocks.
#pragma once

#include "motion/uim242/errors.hpp"
#include "motion/uim242/feedback.hpp"
#include "motion/uim242/instruction.hpp"
#include "motion/uim242/packing.hpp"
