// The simulator's runtime folder and the files in it get their modes explicitly, not from the
// umask: the folder 0700 (0710 with a group), whoever made it before.
#include "motion/core/file_access.hpp"

#include <gtest/gtest.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "motion/testing/temp_dir.hpp"

namespace motion {
namespace {

namespace fs = std::filesystem;

struct FileAccessTest : ::testing::Test {
  FileAccessTest() {
    old_umask = ::umask(0);  // the most permissive umask: nothing may come from it
  }
  ~FileAccessTest() override { ::umask(old_umask); }
  static mode_t mode_of(const fs::path& p) {
    struct stat st {};
    return ::lstat(p.c_str(), &st) == 0 ? st.st_mode & 07777 : 0;
  }
  testing::TempDir tmp{"motion-access"};
  fs::path root = tmp.path();
  mode_t old_umask = 0;
};

TEST_F(FileAccessTest, RuntimeFolderIsTheOwnersAloneWhateverTheUmaskOrItsModeBefore) {
  const fs::path fresh = root / "a" / "runtime";
  ASSERT_FALSE(make_private_dir(fresh.string(), FileAccess{}));
  EXPECT_EQ(mode_of(fresh), 0700U);
  // Left open by an earlier version (or by hand): closed again.
  ASSERT_EQ(::chmod(fresh.c_str(), 0777), 0);
  ASSERT_FALSE(make_private_dir(fresh.string(), FileAccess{}));
  EXPECT_EQ(mode_of(fresh), 0700U);
  // With simulation.group: its members may reach the files by name, not list them.
  ASSERT_FALSE(make_private_dir(fresh.string(), FileAccess{::getgid()}));
  EXPECT_EQ(mode_of(fresh), 0710U);
  struct stat st {};
  ASSERT_EQ(::stat(fresh.c_str(), &st), 0);
  EXPECT_EQ(st.st_gid, ::getgid());
}

TEST_F(FileAccessTest, ASymbolicLinkOrAFileInItsPlaceIsRefusedAndLeftAlone) {
  const fs::path elsewhere = root / "elsewhere";
  fs::create_directory(elsewhere);
  ASSERT_EQ(::chmod(elsewhere.c_str(), 0755), 0);
  const fs::path planted = root / "runtime";
  fs::create_directory_symlink(elsewhere, planted);
  EXPECT_EQ(make_private_dir(planted.string(), FileAccess{}), std::make_error_code(std::errc::not_a_directory));
  EXPECT_EQ(mode_of(elsewhere), 0755U);  // not followed
  const fs::path file = root / "file";
  {
    FILE* f = ::fopen(file.c_str(), "w");
    ASSERT_NE(f, nullptr);
    ::fclose(f);
  }
  EXPECT_TRUE(make_private_dir(file.string(), FileAccess{}));
}

TEST_F(FileAccessTest, AFolderOfAnotherUserIsRefused) {
  // Someone else made it first (a shared /tmp): its files could be theirs to open.
  if (::geteuid() != 0) GTEST_SKIP() << "needs root to give a folder to another user";
  const fs::path theirs = root / "runtime";
  fs::create_directory(theirs);
  ASSERT_EQ(::chown(theirs.c_str(), 65534, 65534), 0);
  ASSERT_EQ(::chmod(theirs.c_str(), 0777), 0);
  EXPECT_EQ(make_private_dir(theirs.string(), FileAccess{}), std::make_error_code(std::errc::permission_denied));
  EXPECT_EQ(mode_of(theirs), 0777U);
}

}  // namespace
}  // namespace motion
