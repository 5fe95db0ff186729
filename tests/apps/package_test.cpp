// The CMake package: `cmake --install` into a temporary prefix puts the one public header and the
// package files there (no internal header); examples/online_consumer configures against it in a
// clean folder with find_package(ovo REQUIRED), builds (-j2) and runs on a short simulated
// dataset: it prints a pose for every frame, and its final trajectory is `ovo run`'s.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/apps/online_test_data.hpp"
#include "tests/test_support.hpp"

namespace ovo {
namespace {

namespace fs = std::filesystem;

std::vector<std::vector<double>> readTumRows(const fs::path& file) {
  std::vector<std::vector<double>> rows;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::stringstream ss(line);
    std::vector<double> row;
    double v;
    while (ss >> v) row.push_back(v);
    rows.push_back(row);
  }
  return rows;
}

TEST(Package, ExampleConsumerBuildsAgainstTheInstalledPackageAndRuns) {
  if (!fs::exists(test::ovoBinaryPath())) GTEST_SKIP() << "ovo not built";
  const fs::path build = OVO_BINARY_DIR;
  const fs::path work = build / "package_test";
  fs::remove_all(work);
  fs::create_directories(work);
  const std::string cmake = std::string("'") + OVO_CMAKE_COMMAND + "'";
  std::string output;
  ASSERT_EQ(test::runShell(cmake + " --install '" + build.string() + "' --prefix '" +
                               (work / "prefix").string() + "'",
                           work, &output),
            0)
      << output;
  // The public header and nothing else of the source tree.
  std::vector<std::string> headers;
  for (const auto& e : fs::recursive_directory_iterator(work / "prefix" / "include"))
    if (e.is_regular_file()) headers.push_back(fs::relative(e.path(), work / "prefix" / "include"));
  EXPECT_EQ(headers, std::vector<std::string>{"ovo/ovo.hpp"});
  EXPECT_TRUE(fs::exists(work / "prefix" / "lib" / "cmake" / "ovo" / "ovoConfig.cmake"));
  EXPECT_TRUE(fs::exists(work / "prefix" / "lib" / "cmake" / "ovo" / "ovoConfigVersion.cmake"));

  // Configure and build the example in a clean folder against the prefix only.
  ASSERT_EQ(test::runShell(cmake + " -S '" + test::sourcePath("examples/online_consumer").string() +
                               "' -B '" + (work / "build").string() +
                               "' -G Ninja -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH='" +
                               (work / "prefix").string() + "'",
                           work, &output),
            0)
      << output;
  ASSERT_EQ(
      test::runShell(cmake + " --build '" + (work / "build").string() + "' -j2", work, &output), 0)
      << output;

  // 1.5 s of the default scenario, through the example and through `ovo run`.
  const std::string ovo = "'" + test::ovoBinaryPath().string() + "'";
  const fs::path data = work / "data";
  ASSERT_EQ(test::runShell(ovo + " simulate --config '" +
                               test::sourcePath("configs/sim/vineyard_row.yaml").string() +
                               "' --set duration_s=1.5 --out '" + data.string() + "'",
                           work, &output),
            0)
      << output;
  ASSERT_EQ(test::runShell(ovo + " run --quiet --dataset '" + data.string() + "' --out '" +
                               (work / "run").string() + "'",
                           work, &output),
            0)
      << output;
  const std::string consumer = "'" + (work / "build" / "online_consumer").string() +
                               "' --dataset '" + data.string() + "' --out '" +
                               (work / "final.txt").string() + "'";
  ASSERT_EQ(std::system((consumer + " > '" + (work / "poses.txt").string() + "' 2> '" +
                         (work / "consumer_err.txt").string() + "'")
                            .c_str()),
            0);
  const auto poses = readTumRows(work / "poses.txt");
  const auto final_poses = readTumRows(work / "final.txt");
  const auto run = readTumRows(work / "run" / "trajectory.txt");
  ASSERT_EQ(run.size(), 31u);
  EXPECT_EQ(poses.size(), run.size());  // one pose for every frame, as it was processed
  ASSERT_EQ(final_poses.size(), run.size());
  for (std::size_t i = 0; i < run.size(); ++i) {
    ASSERT_EQ(final_poses[i].size(), 8u);
    for (int k = 0; k < 8; ++k) EXPECT_NEAR(final_poses[i][k], run[i][k], 1e-8) << i << " " << k;
  }
}

}  // namespace
}  // namespace ovo
