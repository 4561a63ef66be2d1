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
  // Of the folder that holds such files: 0700, or 0710 with the group (its members reach the
  // files by their names, they cannot list the folder).
  [[nodiscard]] mode_t dir_mode() const { return group ? 0710 : 0700; }
};

// Sets the mode (and, with a group, the group) of the file at `path` (a Unix socket: call it
// between bind and listen, so that nobody connects before) or of the open `fd` (a pty's slave).
[[nodiscard]] std::error_code restrict_access(const std::string& path, const FileAccess& access);
[[nodiscard]] std::error_code restrict_access(int fd, const FileAccess& access);

// Makes `path` the folder of such files (its missing parents are made as the umask says):
// created, or taken when it exists as a folder (not a symbolic link) owned by this process's
// user, and given dir_mode() (and the group) explicitly, whatever the umask or its mode was. A
// folder of another user (e.g. made first by someone else in /tmp) is refused:
// std::errc::permission_denied; a symbolic link or a file: std::errc::not_a_directory.
[[nodiscard]] std::error_code make_private_dir(const std::string& path, const FileAccess& access);

// The id of the group called `name`; nullopt when there is none.
[[nodiscard]] std::optional<gid_t> group_id(const std::string& name);

}  // namespace motion
