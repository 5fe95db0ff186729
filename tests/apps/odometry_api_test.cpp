// The library's Odometry API (api/ovo.hpp) with the rig's camera-gyro time offset and its
// trajectory option: a rig whose camera.time_offset_s says the images are stamped 30 ms late gives
// the estimator the same data as images stamped on the gyro clock (same poses), the callback's
// stamps are the images' as given and trajectory()'s are on the gyro clock; without the
// trajectory kept, trajectory() holds only the recent past; the "low" budget is ovo run's preset
// (the same poses as its keys given one by one); measurements out of order or not finite are
// refused, counted in status() and change nothing; the poses' twist is the body's velocity.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <regex>
#include <sstream>

#include "api/ovo.hpp"
#include "common/so3.hpp"
#include "io/dataset.hpp"
#include "tests/apps/simulated_row.hpp"

namespace ovo {
namespace {

namespace fs = std::filesystem;

struct ApiRun {
  std::vector<Pose> streamed, trajectory;
  Status status;  // after finish()
};

/// Feeds the dataset through the API in time order (offline mode), the images stamped
/// `image_delay_ns` late, with the rig at rig_file. `bad`: at every 50th image, four measurements
/// the API must refuse (a gyro sample and an image not after the previous, a gyro sample with a
/// NaN, a scan with a non-finite angle).
ApiRun runApi(const io::Dataset& data, const fs::path& rig_file, Timestamp image_delay_ns,
              bool keep_trajectory = true, OdometryOptions options = {}, bool bad = false) {
  options.keep_trajectory = keep_trajectory;
  ApiRun run;
  Odometry odo(rig_file.string(), options, [&](const Pose& p) { run.streamed.push_back(p); });
  std::size_t g = 0, s = 0;
  for (std::size_t i = 0; i < data.images.size(); ++i) {
    const Timestamp t = data.images[i].t_ns;
    if (bad && i > 0 && i % 50 == 0 && g > 0) {
      const Timestamp last_gyro = data.imu[g - 1].t_ns;
      EXPECT_FALSE(odo.addGyro({last_gyro, 0.1, 0.0, 0.0}));
      EXPECT_FALSE(odo.addGyro({last_gyro + 1, std::nan(""), 0.0, 0.0}));
      EXPECT_FALSE(odo.addImage(data.images[i - 1].t_ns + image_delay_ns,
                                io::loadDatasetImage(data, i - 1)));
      Scan broken{t, std::numeric_limits<double>::infinity(), 0.01, 0.1, 30.0, 0.0, {1.0f}};
      EXPECT_FALSE(odo.addScan(broken));
    }
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
  run.status = odo.status();
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
    // On the gyro clock: the same for both, the image's time but for the window's own estimate.
    EXPECT_EQ(late.streamed[i].t_gyro_clock_ns, plain.streamed[i].t_gyro_clock_ns);
    EXPECT_NEAR(late.streamed[i].t_gyro_clock_ns, data.images[i].t_ns, 5e6);
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

TEST(OdometryApi, RefusedMeasurementsAreCountedAndChangeNothing) {
  const fs::path dataset = test::simulatedRow(6);
  const io::Dataset data = io::loadDataset(dataset);
  const fs::path tmp = fs::temp_directory_path() / ("ovo_api_refuse_" + std::to_string(::getpid()));
  const fs::path rig = rigWithOffset(dataset, tmp, 0.0);
  const ApiRun clean = runApi(data, rig, 0);
  const ApiRun fed_bad = runApi(data, rig, 0, true, {}, true);
  fs::remove_all(tmp);
  EXPECT_EQ(clean.status.refused, 0);
  EXPECT_EQ(fed_bad.status.refused, 4 * static_cast<int>((data.images.size() - 1) / 50));
  ASSERT_EQ(fed_bad.trajectory.size(), clean.trajectory.size());
  for (std::size_t i = 0; i < clean.trajectory.size(); ++i)
    ASSERT_EQ(fed_bad.trajectory[i].position_m, clean.trajectory[i].position_m) << "frame " << i;
  // The status of the run's end: every image processed, the window's offset estimated.
  EXPECT_EQ(clean.status.frames_processed, static_cast<int>(data.images.size()));
  EXPECT_EQ(clean.status.frames_dropped, 0);
  EXPECT_TRUE(clean.status.tracking);
  EXPECT_EQ(clean.status.tracking_losses, 0);
  EXPECT_GT(clean.status.solve_ms, 0.0);
  EXPECT_TRUE(clean.status.time_offset_estimated);
  EXPECT_LT(std::abs(clean.status.time_offset_s), 0.005);
  EXPECT_TRUE(clean.status.error.empty());
}

// The twist the poses carry (nav_msgs/Odometry's) against the truth's: the body-frame velocity
// and angular velocity of the ground truth differenced over the same frames, through a headland
// turn (a velocity in the world frame, or rotated the wrong way, is off by the speed once the
// robot has turned 90 deg; an angular velocity of the wrong sign by twice the turn rate).
TEST(OdometryApi, ThePosesTwistIsTheBodysVelocity) {
  const fs::path dataset = test::simulatedRow(14, "headland_turn");
  const io::Dataset data = io::loadDataset(dataset);
  ASSERT_FALSE(data.groundtruth.empty());
  const fs::path tmp = fs::temp_directory_path() / ("ovo_api_twist_" + std::to_string(::getpid()));
  const ApiRun run = runApi(data, rigWithOffset(dataset, tmp, 0.0), 0);
  fs::remove_all(tmp);
  const auto truth_at = [&](Timestamp t) {  // the nearest ground-truth pose
    auto it = std::lower_bound(data.groundtruth.begin(), data.groundtruth.end(), t,
                               [](const StampedPose& p, Timestamp x) { return p.t_ns < x; });
    if (it == data.groundtruth.end() ||
        (it != data.groundtruth.begin() && t - std::prev(it)->t_ns < it->t_ns - t))
      --it;
    return it->T_W_B;
  };
  struct TwistErrors {
    double speed, speed_err, turn_rate, turn_rate_err;
    std::size_t turn_frames;
  };
  const auto median = [](std::vector<double> x) {
    std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
    return x[x.size() / 2];
  };
  const auto errors = [&](const std::vector<Pose>& poses, bool on_gyro_clock) {
    std::vector<double> speed_err, speeds, turn_rate_err, turn_rates;
    for (std::size_t i = 1; i < poses.size(); ++i) {
      const Pose& p = poses[i];
      const Pose& prev = poses[i - 1];
      const Timestamp t0 = on_gyro_clock ? prev.t_gyro_clock_ns : prev.t_ns;
      const Timestamp t1 = on_gyro_clock ? p.t_gyro_clock_ns : p.t_ns;
      const SE3 a = truth_at(t0), b = truth_at(t1);
      const double dt = toSeconds(t1 - t0);
      const Vec3 v = b.linear().transpose() * (b.translation() - a.translation()) / dt;
      const Vec3 w = so3::log(a.linear().transpose() * b.linear()) / dt;
      const Vec3 v_est(p.velocity_body_mps[0], p.velocity_body_mps[1], p.velocity_body_mps[2]);
      const Vec3 w_est(p.angular_velocity_body_radps[0], p.angular_velocity_body_radps[1],
                       p.angular_velocity_body_radps[2]);
      speed_err.push_back((v_est - v).norm());
      speeds.push_back(v.norm());
      if (std::abs(w.z()) > 0.2) {  // in the turn
        turn_rate_err.push_back((w_est - w).norm());
        turn_rates.push_back(std::abs(w.z()));
      }
    }
    if (turn_rates.empty()) return TwistErrors{median(speeds), median(speed_err), 0, 0, 0};
    return TwistErrors{median(speeds), median(speed_err), median(turn_rates), median(turn_rate_err),
                       turn_rates.size()};
  };
  // The final poses, and the poses as they went out (what a ROS node publishes).
  const TwistErrors final_twist = errors(run.trajectory, true);
  const TwistErrors online_twist = errors(run.streamed, true);
  for (const TwistErrors& e : {final_twist, online_twist}) {
    EXPECT_GT(e.speed, 0.5);
    ASSERT_GT(e.turn_frames, 20u);
  }
  EXPECT_LT(final_twist.speed_err, 0.03 * final_twist.speed);
  EXPECT_LT(final_twist.turn_rate_err, 0.05 * final_twist.turn_rate);
  EXPECT_LT(online_twist.speed_err, 0.05 * online_twist.speed);
  EXPECT_LT(online_twist.turn_rate_err, 0.05 * online_twist.turn_rate);
  std::printf("twist: final %.4f of %.3f m/s, %.4f of %.3f rad/s; online %.4f m/s, %.4f rad/s\n",
              final_twist.speed_err, final_twist.speed, final_twist.turn_rate_err,
              final_twist.turn_rate, online_twist.speed_err, online_twist.turn_rate_err);
  // The first pose has none.
  EXPECT_EQ(run.streamed.front().velocity_body_mps, (std::array<double, 3>{0, 0, 0}));
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
