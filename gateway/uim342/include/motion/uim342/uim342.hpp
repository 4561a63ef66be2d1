// Umbrella header of motion::uim342, the pure UIM342 SimpleCAN 3.0 codec (no I/O):
//   identifier.hpp    29-bit CAN identifier layout, ID kinds (§2.5)
//   message.hpp       CW DL d0..d7 and its CAN frame carriage
//   instructions.hpp  function codes, sub-index enums, typed instructions/replies, form table
//   notifications.hpp real-time notifications (CW 0x5A)
//   matching.hpp      expected reply of a request, classification of incoming frames (§3.1)
//   uimessage.hpp     16-byte serial/USB/Ethernet gateway framing with CRC-16/MODBUS (§2.6)
//   uimessage_stream.hpp  UIMessages out of a serial byte stream, with resynchronization
//   parameters.hpp    value ranges, drive-side checks, unit conversions
//   errors.hpp        "uim342" drive error category, codec errors, Result<T>
#pragma once

#include "motion/uim342/errors.hpp"
#include "motion/uim342/identifier.hpp"
#include "motion/uim342/instructions.hpp"
#include "motion/uim342/matching.hpp"
#include "motion/uim342/message.hpp"
#include "motion/uim342/notifications.hpp"
#include "motion/uim342/parameters.hpp"
#include "motion/uim342/uimessage.hpp"
#include "motion/uim342/uimessage_stream.hpp"
