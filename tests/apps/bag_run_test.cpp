// Bags through the `ovo` command: the same short simulated sequence written as a folder (`ovo
// simulate`), as an MCAP (`ovo simulate --format mcap`) and converted into a ROS 1 bag and a
// rosbag2 sqlite3 folder (`ovo convert`) gives byte-identical trajectories with `ovo run`; a bag
// converts back into a folder; bad bags end the command with an error naming the bag.
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "io/rosbag1_reader.hpp"
#include "tests/apps/online_test_data.hpp"
#include "tests/test_support.hpp"

namespace ovo {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string q(const fs::path& p) {
  std::string s = "'";  // (GCC 12 warns falsely about "'" + p.string() + "'")
  s += p.string();
  s += '\'';
  return s;
}

// Simulated once per test program, outside tempDir() (which each test empties).
const fs::path& workDir() {
  static const fs::path dir = [] {
    const fs::path d = fs::temp_directory_path() / ("ovo_bag_test_" + std::to_string(::getpid()));
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
  }();
  return dir;
}

TEST(BagRun, FolderRos1Db3AndMcapGiveIdenticalTrajectories) {
  if (!fs::exists(test::ovoBinaryPath())) GTEST_SKIP() << "ovo not built";
  const fs::path dir = workDir();
  // 1.5 s of the default scenario (the robot drives off after 0.5 s): 31 frames.
  const std::string sim = "simulate --config " +
                          q(test::sourcePath("configs/sim/vineyard_row.yaml")) +
                          " --set duration_s=1.5 --out ";
  std::string err;
  ASSERT_EQ(test::runOvo(sim + q(dir / "folder"), nullptr, &err), 0) << err;
  ASSERT_EQ(test::runOvo(sim + q(dir / "mcap") + " --format mcap", nullptr, &err), 0) << err;
  ASSERT_TRUE(fs::exists(dir / "mcap" / "run.mcap"));
  // A build without ROS 1 bags (OVO_WITH_ROS1=OFF) compares the folder, db3 and MCAP.
  const bool ros1 = io::bag::ros1BagsBuilt();
  for (const char* format : {"rosbag", "db3"}) {
    if (std::string(format) == "rosbag" && !ros1) continue;
    ASSERT_EQ(test::runOvo("convert --in " + q(dir / "folder") + " --out " + q(dir / format) +
                               " --format " + format,
                           nullptr, &err),
              0)
        << err;
  }
  if (ros1) ASSERT_TRUE(fs::exists(dir / "rosbag" / "run.bag"));
  ASSERT_TRUE(fs::exists(dir / "db3" / "run" / "metadata.yaml"));

  std::vector<std::pair<std::string, fs::path>> inputs = {{"folder", dir / "folder"},
                                                          {"db3", dir / "db3" / "run"},
                                                          {"mcap", dir / "mcap" / "run.mcap"}};
  if (ros1) inputs.emplace_back("rosbag", dir / "rosbag" / "run.bag");
  std::string reference;
  for (const auto& [name, input] : inputs) {
    SCOPED_TRACE(name);
    std::string out;
    ASSERT_EQ(test::runOvo("run --estimator window --dataset " + q(input) + " --out " +
                               q(dir / ("run_" + name)),
                           &out, &err),
              0)
        << err;
    // The summary names the accuracy (the ground truth beside the bag) and the report.
    EXPECT_CONTAINS(out, "ATE ");
    EXPECT_CONTAINS(out, "report: " + (dir / ("run_" + name) / "report.html").string());
    const std::string trajectory = slurp(dir / ("run_" + name) / "trajectory.txt");
    EXPECT_GT(std::count(trajectory.begin(), trajectory.end(), '\n'), 30);
    if (reference.empty())
      reference = trajectory;
    else
      EXPECT_TRUE(trajectory == reference) << "trajectory.txt differs from the folder's";
  }
  // The ROS 1 bag converts back into the folder's measurements.
  if (!ros1) return;
  ASSERT_EQ(
      test::runOvo("convert --in " + q(dir / "rosbag" / "run.bag") + " --out " + q(dir / "back"),
                   nullptr, &err),
      0)
      << err;
  EXPECT_EQ(slurp(dir / "back" / "imu0" / "data.csv"), slurp(dir / "folder" / "imu0" / "data.csv"));
  EXPECT_EQ(slurp(dir / "back" / "cam0" / "data.csv"), slurp(dir / "folder" / "cam0" / "data.csv"));
}

TEST(BagRun, BadBagsEndTheCommandWithAnError) {
  if (!fs::exists(test::ovoBinaryPath())) GTEST_SKIP() << "ovo not built";
  const fs::path dir = test::tempDir().parent_path() / "bag_run_bad";
  fs::remove_all(dir);
  fs::create_directories(dir);
  test::writeTextFile(dir / "cut.mcap", std::string("\x89MCAP0\r\n\x01\x10", 10));
  std::string err;
  EXPECT_EQ(test::runOvo("run --dataset " + q(dir / "cut.mcap"), nullptr, &err), 2);
  EXPECT_CONTAINS(err, (dir / "cut.mcap").string());
  EXPECT_CONTAINS(err, "truncated");
  test::writeTextFile(dir / "x.bag", "#ROSBAG V2.0\n");
  EXPECT_EQ(
      test::runOvo("convert --in " + q(dir / "x.bag") + " --out " + q(dir / "o"), nullptr, &err),
      2);
  EXPECT_CONTAINS(err, (dir / "x.bag").string());
  EXPECT_FALSE(fs::exists(dir / "o"));  // nothing half-written
  OVO_REQUIRE_ROS1();
  OVO_REQUIRE_DATA("rosbag-fixtures/ros1_laserscan_hokuyo/demo.bag");
  test::writeTextFile(dir / "rig.yaml", "camera: {rate_hz: 20}\n");
  EXPECT_EQ(test::runOvo("run --rig " + q(dir / "rig.yaml") + " --dataset " +
                             q(test::sharedData("rosbag-fixtures/ros1_laserscan_hokuyo/demo.bag")),
                         nullptr, &err),
            2);
  EXPECT_CONTAINS(err, "no camera topic");
}

}  // namespace
}  // namespace ovo
