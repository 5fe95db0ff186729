// `ovo run --out`: a second run replaces the first one's output (with or without a trailing
// slash), and a path that holds anything else (a file, the dataset itself) is refused before any
// work, with exit code 2, leaving it as it was.
#include <gtest/gtest.h>

#include <fstream>
#include <set>
#include <sstream>

#include "tests/apps/online_test_data.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

std::set<std::string> entries(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

TEST(RunOutput, ReplacesOnlyItsOwnEarlierOutput) {
  OVO_REQUIRE_DATA("kitti07-first160/image_0/000000.png");
  if (!fs::exists(ovoBinaryPath())) GTEST_SKIP() << "not built: " << ovoBinaryPath().string();
  const fs::path dir = tempDir();
  const fs::path data = makeMiniKitti(dir / "kitti", 8);
  const std::string run = "'" + ovoBinaryPath().string() + "' run --quiet --estimator vo " +
                          "--dataset '" + data.string() + "' --out ";
  std::string out;
  ASSERT_EQ(runShell(run + "'" + (dir / "run").string() + "'", dir, &out), 0) << out;
  const std::set<std::string> written = entries(dir / "run");
  EXPECT_TRUE(written.count("trajectory.txt") && written.count("metrics.json")) << out;
  std::ofstream(dir / "run" / "metrics.json") << "stale";
  ASSERT_EQ(runShell(run + "'" + (dir / "run").string() + "/'", dir, &out), 0) << out;
  EXPECT_EQ(entries(dir / "run"), written);
  std::ifstream in(dir / "run" / "metrics.json");
  std::stringstream metrics;
  metrics << in.rdbuf();
  EXPECT_NE(metrics.str(), "stale");

  // The dataset folder itself: refused, nothing touched.
  const std::set<std::string> dataset = entries(data);
  EXPECT_EQ(runShell(run + "'" + data.string() + "'", dir, &out), 2);
  EXPECT_CONTAINS(out, "the folder holds '");
  EXPECT_CONTAINS(out, "which is not output of this command");
  EXPECT_EQ(entries(data), dataset);
  // A file.
  std::ofstream(dir / "notes.txt") << "precious";
  EXPECT_EQ(runShell(run + "'" + (dir / "notes.txt").string() + "'", dir, &out), 2);
  EXPECT_CONTAINS(out, "notes.txt': exists and is not a folder");
  EXPECT_EQ(fs::file_size(dir / "notes.txt"), 8u);
  // No staging folder is left behind by any of these.
  for (const auto& name : entries(dir))
    EXPECT_EQ(name.find(".partial-"), std::string::npos) << name;
}

}  // namespace
}  // namespace ovo::test
