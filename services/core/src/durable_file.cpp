#include "motion/core/durable_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include <fmt/format.h>

#include "motion/core/precise_timer.hpp"

namespace motion {

namespace {

std::string failure(const char* call, const std::string& path, int error) {
  return fmt::format("{} {}: {}", call, path, std::strerror(error));
}

// fsync, retried on EINTR.
int sync_fd(int fd) {
  int rc = 0;
  do { rc = ::fsync(fd); } while (rc != 0 && errno == EINTR);
  return rc;
}

}  // namespace

std::string write_file_durably(const std::string& path, const std::string& text, unsigned mode) {
  const std::string temporary = fmt::format("{}.tmp", path);
  const int fd = ::open(temporary.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, mode);
  if (fd < 0) return failure("cannot write", temporary, errno);
  bool ok = ::fchmod(fd, mode) == 0;  // whatever mode an old temporary file had
  const char* call = "cannot set the mode of";
  for (std::size_t done = 0; ok && done < text.size();) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n < 0 && errno == EINTR) continue;
    ok = n > 0;
    call = "cannot write";
    if (ok) done += static_cast<std::size_t>(n);
  }
  if (ok) {
    ok = sync_fd(fd) == 0;
    call = "cannot sync";
  }
  const int error = errno;
  ::close(fd);
  if (!ok) {
    ::unlink(temporary.c_str());
    return failure(call, temporary, error);
  }
  if (::rename(temporary.c_str(), path.c_str()) != 0) {
    const int rename_error = errno;
    ::unlink(temporary.c_str());
    return fmt::format("cannot rename {} to {}: {}", temporary, path, std::strerror(rename_error));
  }
  // The rename is durable once the folder's entry is.
  const std::filesystem::path parent = std::filesystem::path(path).parent_path();
  const std::filesystem::path folder = parent.empty() ? std::filesystem::path(".") : parent;
  const int dir = ::open(folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return failure("cannot open the folder", folder.string(), errno);
  const bool synced = sync_fd(dir) == 0;
  const int dir_error = errno;
  ::close(dir);
  return synced ? std::string{} : failure("cannot sync the folder", folder.string(), dir_error);
}

BackgroundFileWriter::BackgroundFileWriter(std::string path, unsigned mode)
    : path_(std::move(path)), mode_(mode), thread_([this] { run(); }) {}

BackgroundFileWriter::~BackgroundFileWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_one();
  thread_.join();  // run() writes what is pending before it returns
}

void BackgroundFileWriter::write(std::string text) {
  {
    std::lock_guard lock(mutex_);
    pending_ = std::move(text);
    ++handed_over_;
  }
  wake_.notify_one();
}

void BackgroundFileWriter::flush() {
  std::unique_lock lock(mutex_);
  const std::uint64_t target = handed_over_;
  finished_.wait(lock, [&] { return covered_ >= target; });
}

std::string BackgroundFileWriter::last_error() const {
  std::lock_guard lock(mutex_);
  return last_error_;
}

bool BackgroundFileWriter::pending() const {
  std::lock_guard lock(mutex_);
  return pending_.has_value();
}

std::uint64_t BackgroundFileWriter::writes() const {
  std::lock_guard lock(mutex_);
  return writes_;
}

void BackgroundFileWriter::run() {
  normal_scheduling();  // not a real-time owner's SCHED_FIFO: this thread waits on the disk
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [&] { return pending_.has_value() || stopping_; });
    if (!pending_) return;  // stopping, nothing left
    std::string text = std::move(*pending_);
    pending_.reset();
    const std::uint64_t covers = handed_over_;  // every text handed over so far is superseded by this one
    lock.unlock();
    std::string error = write_file_durably(path_, text, mode_);
    lock.lock();
    last_error_ = std::move(error);
    covered_ = covers;
    ++writes_;
    finished_.notify_all();
  }
}

}  // namespace motion
