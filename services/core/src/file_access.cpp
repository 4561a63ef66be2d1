#include "motion/core/file_access.hpp"

#include <fcntl.h>
#include <grp.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <vector>

namespace motion {
namespace {

std::error_code last_error() { return {errno, std::generic_category()}; }

}  // namespace

std::error_code restrict_access(const std::string& path, const FileAccess& access) {
  // Group first: a chown may clear set-id bits, and the mode is what must hold in the end.
  if (access.group && ::lchown(path.c_str(), static_cast<uid_t>(-1), *access.group) != 0) return last_error();
  if (::fchmodat(AT_FDCWD, path.c_str(), access.mode(), 0) != 0) return last_error();
  return {};
}

std::error_code restrict_access(int fd, const FileAccess& access) {
  if (access.group && ::fchown(fd, static_cast<uid_t>(-1), *access.group) != 0) return last_error();
  if (::fchmod(fd, access.mode()) != 0) return last_error();
  return {};
}

std::error_code make_private_dir(const std::string& path, const FileAccess& access) {
  std::error_code error;
  if (const auto parent = std::filesystem::path(path).parent_path(); !parent.empty()) {
    std::filesystem::create_directories(parent, error);
    if (error) return error;
  }
  if (::mkdir(path.c_str(), 0700) != 0 && errno != EEXIST) return last_error();
  // O_NOFOLLOW | O_DIRECTORY: a symbolic link planted in its place is refused, and what is
  // checked and changed below is the folder opened, not whatever the name points to meanwhile.
  const int fd = ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return errno == ELOOP ? std::make_error_code(std::errc::not_a_directory) : last_error();
  struct stat st {};
  // Steps in order, each only when the ones before succeeded: the same `last_error()` in several
  // branches is not one branch repeated (bugprone-branch-clone).
  if (::fstat(fd, &st) != 0) {  // NOLINT(bugprone-branch-clone)
    error = last_error();
  } else if (st.st_uid != ::geteuid()) {
    error = std::make_error_code(std::errc::permission_denied);
  } else if (access.group && ::fchown(fd, static_cast<uid_t>(-1), *access.group) != 0) {
    error = last_error();
  } else if (::fchmod(fd, access.dir_mode()) != 0) {
    error = last_error();
  }
  ::close(fd);
  return error;
}

std::optional<gid_t> group_id(const std::string& name) {
  group entry{};
  group* found = nullptr;
  std::vector<char> buffer(4096);
  while (::getgrnam_r(name.c_str(), &entry, buffer.data(), buffer.size(), &found) == ERANGE &&
         buffer.size() < (1U << 20)) {
    buffer.resize(buffer.size() * 2);
  }
  if (found == nullptr) return std::nullopt;
  return found->gr_gid;
}

}  // namespace motion
