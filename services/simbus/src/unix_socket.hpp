// Internal: the few socket calls the hub and the endpoint share.
#pragma once

#include <sys/socket.h>
#include <sys/un.h>

#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <system_error>

#include "motion/simbus/wire.hpp"

namespace motion::simbus::detail {

[[nodiscard]] inline std::error_code last_error() { return {errno, std::generic_category()}; }

// nullopt when the path does not fit sun_path.
[[nodiscard]] std::optional<sockaddr_un> unix_address(const std::filesystem::path& path);

// A non-blocking, close-on-exec SOCK_SEQPACKET socket connected to `path`, or -1 (`error` set).
[[nodiscard]] int connect_seqpacket(const std::filesystem::path& path, std::error_code& error);

// Sends one message without blocking; an error code (EAGAIN as resource_unavailable_try_again).
std::error_code send_message(int fd, const wire::Message& message);

// Asks the kernel to stamp what `fd` receives (SO_TIMESTAMPNS): an AF_UNIX datagram is stamped
// when the sender's send() queues it, not when it is read.
void stamp_receptions(int fd);

// Receives one message without blocking into `buffer`: its size, or -1 with errno set (EAGAIN:
// nothing waiting). `sent_wall_ns`: its send time on the wall clock (CLOCK_REALTIME, ns), or 0
// when the kernel gave no stamp.
ssize_t receive_stamped(int fd, std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns);

}  // namespace motion::simbus::detail
