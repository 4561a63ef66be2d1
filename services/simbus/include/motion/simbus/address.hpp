// Where the hub of a simulated bus listens: one Unix-domain SOCK_SEQPACKET socket per bus, named
// after the bus. Pure path arithmetic plus environment lookup; thread-safe.
#pragma once

#include <filesystem>
#include <string_view>

namespace motion::simbus {

// $MOTION_SIM_DIR, else $XDG_RUNTIME_DIR, else /tmp.
[[nodiscard]] std::filesystem::path default_socket_dir();

// Bus names: 1..64 characters of [A-Za-z0-9_.-] (they become file names).
[[nodiscard]] bool valid_bus_name(std::string_view name);

// <dir>/motion-simbus-<name>.sock; `dir` empty means default_socket_dir().
[[nodiscard]] std::filesystem::path socket_path(std::string_view bus_name, const std::filesystem::path& dir = {});

}  // namespace motion::simbus
