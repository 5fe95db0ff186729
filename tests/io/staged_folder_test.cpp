// The output folder of `ovo run` and `ovo simulate`: written beside the target and moved into
// place at commit; what is at the target survives a failed run, and only a folder the command may
// replace is replaced (never a file, a foreign folder, or the folder the user stands in).
#include "io/staged_folder.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "tests/test_support.hpp"

namespace ovo::io {
namespace {

namespace fs = std::filesystem;
using test::errorOf;
using Replace = StagedFolder::Replace;

const std::set<std::string> kOwn = {"trajectory.txt", "metrics.json"};

std::string readAll(const fs::path& file) {
  std::ifstream in(file);
  return {std::istreambuf_iterator<char>(in), {}};
}

/// Entries of `dir` (names only).
std::set<std::string> entries(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

TEST(StagedFolder, NewFolderAppearsOnlyAtCommit) {
  const fs::path dir = test::tempDir();
  {
    StagedFolder out(dir / "a" / "run", "--out", Replace::kIfOwnOutput, kOwn);
    test::writeTextFile(out.staging() / "trajectory.txt", "new");
    EXPECT_FALSE(fs::exists(dir / "a" / "run"));
    EXPECT_EQ(out.staging().parent_path(), dir / "a");
    out.commit();
  }
  EXPECT_EQ(readAll(dir / "a" / "run" / "trajectory.txt"), "new");
  EXPECT_EQ(entries(dir / "a"), std::set<std::string>{"run"});  // no staging folder left
}

TEST(StagedFolder, WithoutCommitTheEarlierOutputStaysAndStagingGoes) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "run" / "trajectory.txt", "old");
  {
    StagedFolder out(dir / "run", "--out", Replace::kIfOwnOutput, kOwn);
    test::writeTextFile(out.staging() / "trajectory.txt", "half");
  }  // a failed run: no commit
  EXPECT_EQ(readAll(dir / "run" / "trajectory.txt"), "old");
  EXPECT_EQ(entries(dir), std::set<std::string>{"run"});
}

TEST(StagedFolder, EarlierOwnOutputIsReplacedAlsoWithATrailingSlash) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "run" / "trajectory.txt", "old");
  test::writeTextFile(dir / "run" / "metrics.json", "{}");
  StagedFolder out((dir / "run").string() + "/", "--out", Replace::kIfOwnOutput, kOwn);
  EXPECT_EQ(out.target(), dir / "run");
  EXPECT_EQ(out.staging().parent_path(), dir);  // beside the target, not inside it
  test::writeTextFile(out.staging() / "trajectory.txt", "new");
  out.commit();
  EXPECT_EQ(entries(dir / "run"), std::set<std::string>{"trajectory.txt"});
  EXPECT_EQ(readAll(dir / "run" / "trajectory.txt"), "new");
}

TEST(StagedFolder, RefusesWhatItMustNotReplaceBeforeAnyWork) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "file.txt", "precious");
  EXPECT_CONTAINS(
      errorOf([&] { StagedFolder(dir / "file.txt", "--out", Replace::kIfOwnOutput, kOwn); }),
      "file.txt': exists and is not a folder");
  EXPECT_EQ(readAll(dir / "file.txt"), "precious");

  // A dataset (or any folder) holding something the command did not write.
  test::writeTextFile(dir / "ds" / "metrics.json", "{}");
  test::writeTextFile(dir / "ds" / "imu0" / "data.csv", "1,0,0,0,0,0,0\n");
  const std::string err =
      errorOf([&] { StagedFolder(dir / "ds", "--out", Replace::kIfOwnOutput, kOwn); });
  EXPECT_CONTAINS(err, "--out '" + (dir / "ds").string() + "': the folder holds 'imu0'");
  EXPECT_TRUE(fs::exists(dir / "ds" / "imu0" / "data.csv"));

  EXPECT_CONTAINS(errorOf([&] { StagedFolder(dir / "ds", "--out", Replace::kIfEmpty); }),
                  "already exists and is not an empty folder");
  // An empty folder may be used under every policy.
  fs::create_directories(dir / "empty");
  EXPECT_NO_THROW(StagedFolder(dir / "empty", "--out", Replace::kIfEmpty));

  // A parent that is a file: the error names the option and comes at once.
  EXPECT_CONTAINS(
      errorOf([&] { StagedFolder(dir / "file.txt" / "sub", "--out", Replace::kIfEmpty); }),
      "--out '" + (dir / "file.txt" / "sub").string() + "': cannot create a folder beside it");
  EXPECT_CONTAINS(errorOf([&] { StagedFolder("", "--out", Replace::kIfEmpty); }),
                  "--out: empty path");
  EXPECT_EQ(entries(dir), (std::set<std::string>{"ds", "empty", "file.txt"}));
}

TEST(StagedFolder, RefusesTheCurrentFolderAndItsParents) {
  const fs::path dir = test::tempDir();
  fs::create_directories(dir / "here" / "deeper");
  const fs::path cwd = fs::current_path();
  fs::current_path(dir / "here" / "deeper");
  // Even under kAlways (simulate --overwrite): replacing them would delete the folder in use.
  const std::string dot = errorOf([&] { StagedFolder(".", "--out", Replace::kAlways); });
  const std::string up = errorOf([&] { StagedFolder("../", "--out", Replace::kAlways); });
  fs::current_path(cwd);
  EXPECT_CONTAINS(dot, "--out '.': that folder holds the current folder");
  EXPECT_CONTAINS(up, "--out '../': that folder holds the current folder");
  EXPECT_TRUE(fs::exists(dir / "here" / "deeper"));
}

TEST(StagedFolder, AlwaysReplacesAFolderButNeverAFile) {
  const fs::path dir = test::tempDir();
  test::writeTextFile(dir / "data" / "anything.txt", "old");
  StagedFolder out(dir / "data", "--out", Replace::kAlways);
  test::writeTextFile(out.staging() / "rig.yaml", "new");
  out.commit();
  EXPECT_EQ(entries(dir / "data"), std::set<std::string>{"rig.yaml"});
  test::writeTextFile(dir / "plain", "x");
  EXPECT_CONTAINS(errorOf([&] { StagedFolder(dir / "plain", "--out", Replace::kAlways); }),
                  "exists and is not a folder");
}

}  // namespace
}  // namespace ovo::io
