// The library's Odometry API (api/ovo.hpp) with the rig's camera-gyro time offset and its
// trajectory option: a rig whose camera.time_offset_s says the images are stamped 30 ms late gives
// the estimator the same data as images stamped on the gyro clock (same poses), the callback's
// stamps are the images' as given and trajectory()'s are on the gyro clock; without the
// trajectory kept, trajectory() holds only the recent past; the "low" budget is ovo run's preset
// (the same poses as its keys given one by one).
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>

#include "api/ovo.hpp"
#include "io/dataset.hpp"
#include "tests/apps/simulated_row.hpp"

namespace ovo {
namespace {

namespace fs = std::filesystem;

struct ApiRun {
  std::vector<Pose> streamed, trajectory;
};

/// Feeds the dataset through the API in time order (offline mode), the images stamped
/// `image_delay_ns` late, with the rig at rig_file.
ApiRun runApi(const io::Dataset& data, const fs::path& rig_file, Timestamp image_delay_ns,
              bool keep_trajectory = true, OdometryOptions options = {}) {
  options.keep_trajectory = keep_trajectory;
  ApiRun run;
  Odometry odo(rig_file.string(), options, [&](const Pose& p) { run.streamed.push_back(p); });
  std::size_t g = 0, s = 0;
  for (std::size_t i = 0; i < data.images.size(); ++i) {
    const Timestamp t = data.images[i].t_ns;
    for (; g < data.imu.size() && data.imu[g].t_ns <= t; ++g) {
      const auto& w = data.imu[g].gyro_radps;
      odo.addGyro({data.imu[g].t_ns, w.x(), w.y(), w.z()});
    }
    for (; s < data.scans.size() && data.scans[s].t_ns <= t; ++s) {
      const LidarScan& l = data.scans[s];
      Scan scan{l.t_ns,
                l.angle_min_rad,
                l.angle_increment_rad,
                l.range_min_m,
                l.range_max_m,
                l.time_increment_s,
                std::vector<float>(l.ranges_m.begin(), l.ranges_m.end())};
      odo.addScan(scan);
    }
    odo.addImage(t + image_delay_ns, io::loadDatasetImage(data, i));
  }
  for (; g < data.imu.size(); ++g) {
    const auto& w = data.imu[g].gyro_radps;
    odo.addGyro({data.imu[g].t_ns, w.x(), w.y(), w.z()});
  }
  odo.finish();
  run.trajectory = odo.trajectory();
  return run;
}

/// The dataset's rig.yaml with camera.time_offset_s set and the calibration named, in `dir`.
fs::path rigWithOffset(const fs::path& dataset, const fs::path& dir, double offset_s) {
  std::ifstream in(dataset / "rig.yaml");
  std::stringstream text;
  text << in.rdbuf();
  const std::string calib = (dataset / "cam0" / "calib_results.txt").string();
  const std::string rig = std::regex_replace(
      text.str(), std::regex("camera: \\{"),
      "camera: {time_offset_s: " + std::to_string(offset_s) + ", calibration: '" + calib + "', ");
  fs::create_directories(dir);
  std::ofstream(dir / "rig.yaml") << rig;
  return dir / "rig.yaml";
}

TEST(OdometryApi, TheRigsTimeOffsetPutsTheImagesOnTheGyroClock) {
  const fs::path dataset = test::simulatedRow(6);
  const io::Dataset data = io::loadDataset(dataset);
  ASSERT_GT(data.images.size(), 100u);
  const fs::path tmp = fs::temp_directory_path() / ("ovo_api_offset_" + std::to_string(::getpid()));
  const Timestamp delay = 30'000'000;
  const ApiRun plain = runApi(data, rigWithOffset(dataset, tmp / "plain", 0.0), 0);
  const ApiRun late = runApi(data, rigWithOffset(dataset, tmp / "late", 0.03), delay);
  fs::remove_all(tmp);
  ASSERT_EQ(late.streamed.size(), data.images.size());
  ASSERT_EQ(plain.streamed.size(), late.streamed.size());
  int keyframes = 0;
  for (std::size_t i = 0; i < data.images.size(); ++i) {
    EXPECT_EQ(late.streamed[i].t_ns, data.images[i].t_ns + delay);  // as given
    EXPECT_EQ(late.streamed[i].position_m, plain.streamed[i].position_m) << "frame " << i;
    EXPECT_EQ(late.streamed[i].orientation_xyzw, plain.streamed[i].orientation_xyzw);
    keyframes += late.streamed[i].is_keyframe;
  }
  EXPECT_GT(keyframes, 5);  // the window ran
  ASSERT_EQ(late.trajectory.size(), plain.trajectory.size());
  for (std::size_t i = 0; i < late.trajectory.size(); ++i) {
    EXPECT_EQ(late.trajectory[i].t_ns, plain.trajectory[i].t_ns);  // the gyro clock
    EXPECT_EQ(late.trajectory[i].position_m, plain.trajectory[i].position_m);
    EXPECT_EQ(late.trajectory[i].is_keyframe, plain.trajectory[i].is_keyframe);
  }
}

TEST(OdometryApi, WithoutTheTrajectoryOnlyTheRecentPastIsKept) {
  const fs::path dataset = test::simulatedRow(10);
  const io::Dataset data = io::loadDataset(dataset);
  const fs::path tmp = fs::temp_directory_path() / ("ovo_api_keep_" + std::to_string(::getpid()));
  const fs::path rig = rigWithOffset(dataset, tmp, 0.0);
  const ApiRun kept = runApi(data, rig, 0, true);
  const ApiRun streamed = runApi(data, rig, 0, false);
  fs::remove_all(tmp);
  EXPECT_EQ(kept.trajectory.size(), data.images.size());
  // The same poses streamed; the trajectory only what the window may still change.
  ASSERT_EQ(streamed.streamed.size(), kept.streamed.size());
  EXPECT_EQ(streamed.streamed.back().position_m, kept.streamed.back().position_m);
  // The window settles frames 5 s old and older once their keyframe has left it.
  EXPECT_LT(streamed.trajectory.size(), data.images.size() * 3 / 4);
  ASSERT_FALSE(streamed.trajectory.empty());
  const std::size_t skip = kept.trajectory.size() - streamed.trajectory.size();
  for (std::size_t i = 0; i < streamed.trajectory.size(); ++i) {  // the kept one's tail
    EXPECT_EQ(streamed.trajectory[i].t_ns, kept.trajectory[skip + i].t_ns);
    EXPECT_EQ(streamed.trajectory[i].position_m, kept.trajectory[skip + i].position_m);
  }
}

TEST(OdometryApi, TheLowBudgetIsOvoRunsPresetAndAnUnknownOneIsRefused) {
  const fs::path dataset = test::simulatedRow(6);
  const io::Dataset data = io::loadDataset(dataset);
  const fs::path tmp = fs::temp_directory_path() / ("ovo_api_budget_" + std::to_string(::getpid()));
  const fs::path rig = rigWithOffset(dataset, tmp, 0.0);
  OdometryOptions low, by_keys;
  low.budget = "low";
  by_keys.settings = {"frontend.half_resolution=true", "window.max_iterations=2"};
  const ApiRun full = runApi(data, rig, 0);
  const ApiRun cheap = runApi(data, rig, 0, true, low);
  const ApiRun keyed = runApi(data, rig, 0, true, by_keys);
  OdometryOptions unknown;
  unknown.budget = "tiny";
  try {
    Odometry odo(rig.string(), unknown, [](const Pose&) {});
    ADD_FAILURE() << "an unknown budget was taken";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("'tiny'"), std::string::npos) << e.what();
  }
  fs::remove_all(tmp);
  ASSERT_EQ(cheap.streamed.size(), data.images.size());
  ASSERT_EQ(keyed.streamed.size(), cheap.streamed.size());
  bool differs_from_full = false;
  for (std::size_t i = 0; i < cheap.streamed.size(); ++i) {
    EXPECT_EQ(cheap.streamed[i].position_m, keyed.streamed[i].position_m) << "frame " << i;
    differs_from_full |= cheap.streamed[i].position_m != full.streamed[i].position_m;
  }
  EXPECT_TRUE(differs_from_full);  // the preset changed the run
}

}  // namespace
}  // namespace ovo
