// Who may open the files that processes of the system create for each other on one machine: the
// sockets of simulated CAN buses and the ptys of simulated serial lines. Whoever can open them can
// inject frames onto a bus, so they are the owner's alone (mode 0600), or the owner's and one
// configured group's (0660, `simulation.group`), never everyone's.
//
// Thread contract: functions without shared state; none blocks (beyond the group database lookup
// of group_id, which may read /etc/group).
#pragma once

#include <sys/types.h>

#include <optional>
#include <string>
#include <system_error>

namespace motion {

struct FileAccess {
  std::optional<gid_t> group;  // nullopt: the owner only
  [[nodiscard]] mode_t mode() const { return group ? 0660 : 0600; }
};

// Sets the mode (and, with a group, the group) of the file at `path` (a Unix socket: call it
// between bind and listen, so that nobody connects before) or of the open `fd` (a pty's slave).
[[nodiscard]] std::error_code restrict_access(const std::string& path, const FileAccess& access);
[[nodiscard]] std::error_code restrict_access(int fd, const FileAccess& access);

// The id of the group called `name`; nullopt when there is none.
[[nodiscard]] std::optional<gid_t> group_id(const std::string& name);

}  // namespace motion
