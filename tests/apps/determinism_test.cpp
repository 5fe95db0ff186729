// Offline runs are deterministic: the same dataset and configuration give a byte-identical
// trajectory.txt (and keyframes.txt) on repeated runs, with the two-stage pipeline and with
// --serial, for each estimator.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "tests/apps/online_test_data.hpp"
#include "tests/apps/simulated_row.hpp"

namespace ovo::test {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

class Determinism : public ::testing::TestWithParam<std::string> {};

TEST_P(Determinism, RepeatedAndSerialRunsWriteByteIdenticalTrajectories) {
  if (!fs::exists(ovoBinaryPath())) GTEST_SKIP() << "not built: " << ovoBinaryPath();
  const fs::path dir = tempDir();
  const fs::path data = simulatedRow(6);
  auto run = [&](const std::string& name, const std::string& extra) {
    std::string out;
    const int code = runShell("'" + ovoBinaryPath().string() + "' run --quiet --estimator " +
                                  GetParam() + " --dataset '" + data.string() + "' --out '" +
                                  (dir / name).string() + "' " + extra,
                              dir, &out);
    EXPECT_EQ(code, 0) << out;
    return slurp(dir / name / "trajectory.txt");
  };
  const std::string first = run("a", "");
  ASSERT_GT(std::count(first.begin(), first.end(), '\n'), 100);  // 120 frames
  EXPECT_EQ(run("b", ""), first) << "a repeated run differs";
  EXPECT_EQ(run("serial", "--serial"), first) << "--serial differs";
  EXPECT_EQ(slurp(dir / "b" / "keyframes.txt"), slurp(dir / "a" / "keyframes.txt"));
  EXPECT_EQ(slurp(dir / "serial" / "keyframes.txt"), slurp(dir / "a" / "keyframes.txt"));
}

INSTANTIATE_TEST_SUITE_P(Estimators, Determinism, ::testing::Values("window", "kf", "vo"),
                         [](const auto& info) { return info.param; });

}  // namespace
}  // namespace ovo::test
