// Small files that must survive a crash or a power cut, written without stalling an event loop.
//
// write_file_durably() replaces a file whole: a temporary file beside it, fsync, rename over the
// old one, fsync of the folder. A reader, a crash or a power cut leaves the old text or the new
// one, never half of one (rename(2) is atomic; the two fsyncs order the data before the rename
// and make the rename itself durable).
//
// Those calls can wait on the file system's journal: a rename over an existing file on ext4 took
// up to 400 ms on a development machine while other processes wrote heavily. A process that keeps
// deadlines (heartbeats, handshakes) must not wait there, so BackgroundFileWriter does the writing
// on a thread of its own, under normal scheduling whatever its owner's (a SCHED_FIFO gateway loop
// must not lend its priority to a thread that waits on the disk).
//
// Thread contract: write_file_durably() blocks (call it off any loop thread, or where blocking is
// fine). BackgroundFileWriter's methods are called from ONE owner thread (typically the event
// loop's); they never wait for I/O, except flush() and the destructor, which wait for the writes
// handed over so far.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

namespace motion {

// Writes `text` to `path` as described above, with mode `mode`: empty, or what failed (naming
// the file and the call).
[[nodiscard]] std::string write_file_durably(const std::string& path, const std::string& text, unsigned mode = 0600);

class BackgroundFileWriter {
 public:
  explicit BackgroundFileWriter(std::string path, unsigned mode = 0600);
  ~BackgroundFileWriter();  // writes what is pending, then stops its thread
  BackgroundFileWriter(const BackgroundFileWriter&) = delete;
  BackgroundFileWriter& operator=(const BackgroundFileWriter&) = delete;

  [[nodiscard]] const std::string& path() const { return path_; }
  // Hands `text` over as the file's next content and returns at once. Texts handed over while a
  // write runs coalesce: only the latest is written next (the file is a snapshot, not a log).
  void write(std::string text);
  // Blocks until every text handed over so far is on disk (or failed). For shutdown and tests.
  void flush();
  // The outcome of the latest finished write: empty when it succeeded, else what failed.
  [[nodiscard]] std::string last_error() const;
  // True while a text handed over waits for the thread to take it.
  [[nodiscard]] bool pending() const;
  // Writes finished (successful or not) since the writer was made.
  [[nodiscard]] std::uint64_t writes() const;

 private:
  void run();

  const std::string path_;
  const unsigned mode_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;      // the thread: something to write, or stop
  std::condition_variable finished_;  // flush(): a write finished
  std::optional<std::string> pending_;
  std::uint64_t handed_over_ = 0;  // texts handed over (write() calls)
  std::uint64_t covered_ = 0;      // of those, how many the finished writes covered
  std::uint64_t writes_ = 0;
  std::string last_error_;
  bool stopping_ = false;
  std::thread thread_;  // last: started when everything above exists
};

}  // namespace motion
