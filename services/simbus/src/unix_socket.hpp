// Internal: the socket call the hub and the endpoint share beyond motion/core/unix_socket.hpp.
#pragma once

#include <cerrno>
#include <system_error>

#include "motion/simbus/wire.hpp"

namespace motion::simbus::detail {

[[nodiscard]] inline std::error_code last_error() { return {errno, std::generic_category()}; }

// Sends one message without blocking; an error code (EAGAIN as resource_unavailable_try_again).
std::error_code send_message(int fd, const wire::Message& message);

}  // namespace motion::simbus::detail
