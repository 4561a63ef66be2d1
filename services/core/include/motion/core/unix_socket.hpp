// Unix-domain SOCK_SEQPACKET sockets between the processes of one machine: the simulated CAN
// buses' hubs and the simulated serial lines (`simulation.serial_link: socket`) listen on one; an
// endpoint or a gateway connects to it. A seqpacket socket keeps each send() one message, tells a
// closed peer (a read of 0, POLLHUP) and can carry the kernel's send stamp of every message, which
// dates a frame by when its sender handed it over, not by when the reader got to it.
//
// Thread contract: functions without shared state; none blocks (every socket is non-blocking).
#pragma once

#include <sys/socket.h>
#include <sys/types.h>
#include <sys/un.h>

#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <system_error>

#include "motion/core/clock.hpp"
#include "motion/core/file_access.hpp"

namespace motion::unix_socket {

// nullopt when the path does not fit sun_path (107 characters).
[[nodiscard]] std::optional<sockaddr_un> address(const std::filesystem::path& path);

// A non-blocking, close-on-exec SOCK_SEQPACKET socket connected to `path`, or -1 (`error` set:
// filename_too_long, or connect's error, e.g. ENOENT when nobody listens there yet).
[[nodiscard]] int connect_seqpacket(const std::filesystem::path& path, std::error_code& error);

// A non-blocking, close-on-exec SOCK_SEQPACKET socket listening at `path` with `access`, or -1
// (`error` set). A socket file left there by a dead process is replaced; one that a live process
// listens on is not: address_in_use. The access is set before listen(), so nobody else connects
// in between.
[[nodiscard]] int listen_seqpacket(const std::filesystem::path& path, const FileAccess& access, std::error_code& error);

// Asks the kernel to stamp what `fd` receives (SO_TIMESTAMPNS): an AF_UNIX message is stamped
// when the sender's send() queues it, not when it is read.
void stamp_receptions(int fd);

// Receives one message without blocking into `buffer`: its size, or -1 with errno set (EAGAIN:
// nothing waiting). `sent_wall_ns`: its send time on the wall clock (CLOCK_REALTIME, ns), or 0
// when the kernel gave no stamp.
ssize_t receive_stamped(int fd, std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns);

// When a message stamped `sent_wall_ns` was sent, on the steady clock whose present is `now`
// (read just after the message): `now` less the stamp's age, at most `longest` (a stepped wall
// clock must not date a message far back); `now` when there is no stamp (0).
[[nodiscard]] TimePoint sent_time(TimePoint now, std::int64_t sent_wall_ns, Duration longest);

}  // namespace motion::unix_socket
