#include "hexsim/common/atomic_file.h"

#include <filesystem>

#include <gtest/gtest.h>

namespace hexsim {
namespace {

namespace fs = std::filesystem;

TEST(AtomicFile, WritesAndLeavesNoTemporary) {
  const fs::path dir = fs::temp_directory_path() / "hexsim_atomic_test";
  fs::remove_all(dir);
  ASSERT_TRUE(EnsureDirectory(dir.string()).ok());
  ASSERT_TRUE(WriteFileAtomic((dir / "a.txt").string(), "hello").ok());
  auto content = ReadFile((dir / "a.txt").string());
  ASSERT_TRUE(content.ok());
  EXPECT_EQ(*content, "hello");
  int files = 0;
  for (const auto& e : fs::directory_iterator(dir)) files += e.is_regular_file();
  EXPECT_EQ(files, 1);
  fs::remove_all(dir);
}

TEST(OutputDirectory, RemovedWhenNotCommitted) {
  const fs::path dir = fs::temp_directory_path() / "hexsim_outdir_test";
  fs::remove_all(dir);
  {
    OutputDirectory out;
    ASSERT_TRUE(out.Open(dir.string()).ok());
    ASSERT_TRUE(WriteFileAtomic(out.File("x"), "1").ok());
  }
  EXPECT_FALSE(fs::exists(dir));
  {
    OutputDirectory out;
    ASSERT_TRUE(out.Open(dir.string()).ok());
    out.Commit();
  }
  EXPECT_TRUE(fs::exists(dir));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace hexsim
