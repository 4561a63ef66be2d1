#include "motion/core/durable_file.hpp"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

namespace motion {
namespace {

namespace fs = std::filesystem;

std::string read_all(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

class DurableFile : public ::testing::Test {
 protected:
  void SetUp() override {
    char pattern[] = "/tmp/motion-durable-XXXXXX";
    ASSERT_NE(::mkdtemp(pattern), nullptr);
    dir_ = pattern;
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(DurableFile, ReplacesTheFileWholeWithTheModeAskedAndLeavesNoTemporaryFile) {
  const fs::path path = dir_ / "record";
  ASSERT_EQ(write_file_durably(path.string(), "old\n", 0644), "");
  ASSERT_EQ(write_file_durably(path.string(), "new text\n", 0600), "");
  EXPECT_EQ(read_all(path), "new text\n");
  struct stat st {};
  ASSERT_EQ(::stat(path.c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0600u);
  EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
}

TEST_F(DurableFile, AFailureNamesTheFileAndTheReasonAndKeepsTheOldText) {
  const fs::path path = dir_ / "record";
  ASSERT_EQ(write_file_durably(path.string(), "kept\n"), "");
  fs::create_directory(path.string() + ".tmp");  // the temporary file cannot be made
  const std::string error = write_file_durably(path.string(), "lost\n");
  EXPECT_NE(error.find(path.string() + ".tmp"), std::string::npos) << error;
  EXPECT_NE(error.find("directory"), std::string::npos) << error;
  EXPECT_EQ(read_all(path), "kept\n");
}

TEST_F(DurableFile, TheWriterReturnsAtOnceWhileTheDiskWaitsAndWritesTheLatestText) {
  const fs::path path = dir_ / "record";
  // A FIFO as the temporary file: opening it for writing blocks until a reader comes, as a
  // rename on a busy journal can block for hundreds of milliseconds.
  ASSERT_EQ(::mkfifo((path.string() + ".tmp").c_str(), 0600), 0);
  BackgroundFileWriter writer(path.string());
  writer.write("first\n");
  for (int i = 0; i < 5000 && writer.pending(); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  ASSERT_FALSE(writer.pending()) << "the thread never took the text";              // it now waits in open(2)
  for (int i = 0; i < 100; ++i) writer.write("text " + std::to_string(i) + "\n");  // returns at once
  EXPECT_EQ(writer.writes(), 0u) << "nothing has finished while the disk waits";
  {
    std::ifstream fifo(path.string() + ".tmp");  // the disk comes back
    std::stringstream got;
    got << fifo.rdbuf();
    EXPECT_EQ(got.str(), "first\n");
  }
  writer.flush();
  // The blocked write failed (a FIFO cannot be synced); the 100 texts handed over meanwhile
  // coalesced into ONE write of the latest.
  EXPECT_EQ(writer.writes(), 2u);
  EXPECT_EQ(writer.last_error(), "");
  EXPECT_EQ(read_all(path), "text 99\n");
}

TEST_F(DurableFile, TheWriterReportsAFailureAndRecoversWithTheNextText) {
  const fs::path path = dir_ / "record";
  fs::create_directory(path.string() + ".tmp");
  BackgroundFileWriter writer(path.string());
  writer.write("one\n");
  writer.flush();
  EXPECT_NE(writer.last_error().find("cannot write " + path.string() + ".tmp"), std::string::npos)
      << writer.last_error();
  fs::remove(path.string() + ".tmp");
  writer.write("two\n");
  writer.flush();
  EXPECT_EQ(writer.last_error(), "");
  EXPECT_EQ(read_all(path), "two\n");
}

TEST_F(DurableFile, TheWriterWritesWhatIsPendingBeforeItIsDestroyed) {
  const fs::path path = dir_ / "record";
  {
    BackgroundFileWriter writer(path.string());
    for (int i = 0; i < 10; ++i) writer.write("text " + std::to_string(i) + "\n");
  }
  EXPECT_EQ(read_all(path), "text 9\n");
}

}  // namespace
}  // namespace motion
