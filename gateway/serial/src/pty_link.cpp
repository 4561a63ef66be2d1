#include "motion/serial/pty_link.hpp"

#include <fcntl.h>
#include <pty.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <filesystem>

namespace motion::serial {

std::unique_ptr<PtyLink> PtyLink::create(const std::string& link_path, const SerialSettings& settings,
                                         std::error_code& error, const FileAccess& access) {
  int master = -1;
  int slave = -1;
  std::array<char, 128> name{};
  if (::openpty(&master, &slave, name.data(), nullptr, nullptr) != 0) {
    error = {errno, std::generic_category()};
    return nullptr;
  }
  auto link = std::unique_ptr<PtyLink>(new PtyLink(master, slave, name.data(), link_path));
  // Before the link is published: nobody else can find the device by it until it is restricted.
  if ((error = restrict_access(slave, access))) return nullptr;
  // Raw on the slave side from the start: a client that opens the link late must not see echoes
  // of what the simulator wrote meanwhile.
  bool parity_modelled = false;  // the line host counts the parity bit in its wire time either way
  if ((error = configure_tty(slave, settings, parity_modelled))) return nullptr;
  const int flags = ::fcntl(master, F_GETFL);
  if (flags < 0 || ::fcntl(master, F_SETFL, flags | O_NONBLOCK) != 0 || ::fcntl(master, F_SETFD, FD_CLOEXEC) != 0 ||
      ::fcntl(slave, F_SETFD, FD_CLOEXEC) != 0) {
    error = {errno, std::generic_category()};
    return nullptr;
  }
  namespace fs = std::filesystem;
  const fs::path target{link_path};
  // Its folder (the simulator's runtime folder) is the owner's too, whatever the umask says.
  if (target.has_parent_path() && (error = make_private_dir(target.parent_path().string(), access))) return nullptr;
  // symlink to a temporary name, then rename over the final one: a gateway polling for the link
  // never sees a half-made or missing link while a stale one is replaced.
  const fs::path temporary = target.string() + ".tmp" + std::to_string(::getpid());
  fs::remove(temporary, error);
  fs::create_symlink(name.data(), temporary, error);
  if (error) return nullptr;
  fs::rename(temporary, target, error);
  if (error) return nullptr;
  return link;
}

PtyLink::PtyLink(int master, int slave, std::string slave_path, std::string link_path)
    : master_(master), slave_(slave), slave_path_(std::move(slave_path)), link_path_(std::move(link_path)) {}

PtyLink::~PtyLink() {
  std::error_code ignored;
  if (std::filesystem::read_symlink(link_path_, ignored) == slave_path_) std::filesystem::remove(link_path_, ignored);
  if (master_ >= 0) ::close(master_);
  if (slave_ >= 0) ::close(slave_);
}

std::size_t PtyLink::read(std::span<std::uint8_t> buffer, std::int64_t& sent_wall_ns) {
  sent_wall_ns = 0;
  const ssize_t n = ::read(master_, buffer.data(), buffer.size());
  return n > 0 ? static_cast<std::size_t>(n) : 0;  // EAGAIN: nothing (the kept slave fd means no EIO)
}

std::error_code PtyLink::write(std::span<const std::uint8_t> bytes) {
  const ssize_t n = ::write(master_, bytes.data(), bytes.size());
  if (n < 0) return {errno, std::generic_category()};
  if (static_cast<std::size_t>(n) != bytes.size())
    return std::make_error_code(std::errc::resource_unavailable_try_again);
  return {};
}

}  // namespace motion::serial
