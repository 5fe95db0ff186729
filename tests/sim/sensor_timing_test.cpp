// Sensor timing realities: the camera's time offset, dropped frames, gyro stamp jitter, the
// auto-exposure, and what `ovo simulate` writes of them.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <set>

#include "io/dataset.hpp"
#include "sim/imu.hpp"
#include "sim/simulation.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

TEST(TimeOffset, ImageStampsAreTheTrueTimesPlusTheOffsetAndTheImagesTheTrueTimes) {
  for (double offset : {-0.05, -0.013, 0.04}) {
    Scenario s = test::exactScenario();
    s.frames = 240;
    s.camera.time_offset_s = offset;
    const Simulation sim(s);
    for (int k : {0, 7, 239}) {
      EXPECT_EQ(sim.frameTrueStamp(k), s.start_time_ns + std::llround(k * 1e9 / s.camera.rate_hz));
      EXPECT_EQ(sim.frameStamp(k) - sim.frameTrueStamp(k), fromSeconds(offset)) << offset;
    }
    // The truth stays on the gyro clock: at every frame's true time and at every image stamp.
    const Trajectory gt = sim.groundTruth();
    std::set<Timestamp> stamps;
    for (const StampedPose& p : gt) stamps.insert(p.t_ns);
    EXPECT_EQ(stamps.size(), gt.size());  // each time once
    for (int k = 0; k < s.frames; ++k) {
      EXPECT_TRUE(stamps.count(sim.frameTrueStamp(k)));
      EXPECT_TRUE(stamps.count(sim.frameStamp(k)));
    }
    for (const StampedPose& p : gt) {
      const double t = toSeconds(p.t_ns - s.start_time_ns);
      EXPECT_TRUE(p.T_W_B.isApprox(sim.trajectory().T_W_B(t), 1e-12));
    }
  }
  // The image is the same whatever the stamp says: rendered at the true time (while driving).
  Scenario s = test::exactScenario();
  s.frames = 201;
  Scenario shifted = s;
  shifted.camera.time_offset_s = 0.03;
  const Simulation a(s), b(shifted);
  EXPECT_EQ(cv::countNonZero(a.renderFrame(200) != b.renderFrame(200)), 0);
  EXPECT_EQ(a.groundTruth().size(), static_cast<std::size_t>(s.frames));  // no offset: frames only
}

TEST(FrameDrops, CountMatchesTheProbabilityAndDependsOnlyOnTheSeedAndFrame) {
  Scenario s = test::exactScenario();
  s.frames = 20000;
  s.camera.frame_drop_probability = 0.05;
  const Simulation sim(s);
  int dropped = 0;
  for (int k = 0; k < s.frames; ++k) dropped += sim.frameDropped(k) ? 1 : 0;
  const double mean = 0.05 * s.frames, sd = std::sqrt(s.frames * 0.05 * 0.95);
  EXPECT_NEAR(dropped, mean, 5.0 * sd);
  const Simulation again(s);
  Scenario other = s;
  other.seed = 2;
  const Simulation another(other);
  int same = 0, differ = 0;
  for (int k = 0; k < 2000; ++k) {
    same += sim.frameDropped(k) == again.frameDropped(k) ? 1 : 0;
    differ += sim.frameDropped(k) != another.frameDropped(k) ? 1 : 0;
  }
  EXPECT_EQ(same, 2000);
  EXPECT_GT(differ, 50);
  s.camera.frame_drop_probability = 0.0;
  const Simulation none(s);
  for (int k = 0; k < 2000; ++k) ASSERT_FALSE(none.frameDropped(k));
}

TEST(ImuJitter, StampsScatterAroundTheTrueTimesWhileTheSamplesStayTheSame) {
  Scenario s = test::defaultScenario();  // noise on: the jitter must not change the samples
  s.frames = 2001;                       // 100 s: 20000 samples
  s.imu.time_jitter_s = 0.0005;
  Scenario still = s;
  still.imu.time_jitter_s = 0.0;
  const Simulation sim(s), ref(still);
  std::vector<GyroBiasSample> bias;
  const std::vector<ImuSample> imu = sim.imu(&bias), exact = ref.imu();
  ASSERT_EQ(imu.size(), exact.size());
  ASSERT_EQ(bias.size(), imu.size());
  double sum = 0.0, sum2 = 0.0, max_abs = 0.0;
  for (std::size_t k = 0; k < imu.size(); ++k) {
    ASSERT_EQ(imu[k].gyro_radps, exact[k].gyro_radps);
    ASSERT_EQ(imu[k].accel_mps2, exact[k].accel_mps2);
    EXPECT_EQ(bias[k].t_ns, exact[k].t_ns);  // the truth stays at the true times
    if (k > 0) {
      ASSERT_GT(imu[k].t_ns, imu[k - 1].t_ns);
    }
    const double e = toSeconds(imu[k].t_ns - exact[k].t_ns);
    sum += e;
    sum2 += e * e;
    max_abs = std::max(max_abs, std::abs(e));
  }
  const double n = static_cast<double>(imu.size());
  const double mean = sum / n, sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 5.0 * 0.0005 / std::sqrt(n));
  EXPECT_NEAR(sd, 0.0005, 0.03 * 0.0005);
  EXPECT_LE(max_abs, 3.0 * 0.0005 + 1e-9);
  EXPECT_GT(max_abs, 2.5 * 0.0005);
}

TEST(AutoExposure, StepsTheGainAgainstTheLightInWholeStepsAtMostAtItsRate) {
  // The robot stands while the light brightens and darkens by up to 30 % over 20 s; the
  // auto-exposure steps its gain by 10 % (at most twice a second) the other way, so the image
  // brightness stays near the first frame's: within a step most of the time.
  Scenario s = test::exactScenario();
  s.frames = 400;
  s.trajectory.start_hold_s = 60.0;
  s.nuisance.exposure_changes = true;
  s.nuisance.exposure_amplitude = 0.3;
  s.nuisance.exposure_period_s = 20.0;
  s.camera.auto_exposure = true;
  s.camera.auto_exposure_step = 0.1;
  s.camera.auto_exposure_rate_hz = 2.0;
  const Simulation sim(s);
  EXPECT_EQ(sim.autoExposureGain(0), 1.0);
  double light_err = 0.0, total_err = 0.0;
  int steps = 0, within_a_step = 0;
  double last_step = -1e9;
  for (int k = 1; k < s.frames; ++k) {
    const double g = sim.autoExposureGain(k), prev = sim.autoExposureGain(k - 1);
    const double n_steps = std::log(g) / std::log(1.1);
    EXPECT_NEAR(n_steps, std::round(n_steps), 1e-9) << k;  // whole steps only
    if (g != prev) {
      EXPECT_NEAR(std::abs(std::log(g / prev)), std::log(1.1), 1e-12);
      EXPECT_GE(sim.frameTime(k) - last_step, 0.5 - 1e-9);
      last_step = sim.frameTime(k);
      ++steps;
    }
    const double light = sim.exposureGain(sim.frameTime(k)) / sim.exposureGain(0.0);
    light_err += std::pow(std::log(light), 2);
    total_err += std::pow(std::log(light * g), 2);
    within_a_step += std::abs(std::log(light * g)) <= std::log(1.1) ? 1 : 0;
  }
  EXPECT_GE(steps, 4);
  EXPECT_LT(total_err, 0.25 * light_err);
  EXPECT_GT(within_a_step, 0.9 * (s.frames - 1));
  // Off: gain 1 throughout.
  s.camera.auto_exposure = false;
  const Simulation off(s);
  EXPECT_EQ(off.autoExposureGain(123), 1.0);
}

TEST(SensorTiming, SimulateWritesTheRealitiesAndTheReaderTakesThemBack) {
  const char* bin = std::getenv("OVO_BIN");
  if (!bin || !std::filesystem::exists(bin)) GTEST_SKIP() << "the ovo binary is not built";
  const auto dir =
      std::filesystem::temp_directory_path() / ("ovo_sim_timing_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const std::string args = "simulate --config " +
                           ::ovo::test::sourcePath("configs/sim/vineyard_row.yaml").string() +
                           " --frames 6 --out " + dir.string() +
                           " --set camera.time_offset_s=-0.025 --set camera.rolling_shutter_s=0.02"
                           " --set camera.frame_drop_probability=0.3 --set imu.time_jitter_s=0.0004"
                           " --set lidar.sweep=true --set rig.camera_time_offset_s=0.01";
  std::string err;
  ASSERT_EQ(::ovo::test::runOvo(args, nullptr, &err), 0) << err;
  const io::Dataset ds = io::loadDataset(dir);
  std::filesystem::remove_all(dir);
  // rig.yaml: the estimator's prior (not the truth) and the readout time.
  EXPECT_EQ(ds.rig.camera_time_offset_s, 0.01);
  EXPECT_EQ(ds.rig.camera_rolling_shutter_s, 0.02);
  ASSERT_TRUE(ds.true_timing);
  EXPECT_EQ(ds.true_timing->camera_time_offset_s, -0.025);
  EXPECT_EQ(ds.true_timing->camera_rolling_shutter_s, 0.02);
  EXPECT_EQ(ds.true_timing->imu_time_jitter_s, 0.0004);
  EXPECT_DOUBLE_EQ(ds.true_timing->lidar_time_increment_s, 0.1 * 0.5 / 360.0);
  EXPECT_EQ(ds.true_timing->camera_frames, 6);
  EXPECT_EQ(static_cast<int>(ds.images.size()),
            ds.true_timing->camera_frames - ds.true_timing->camera_frames_dropped);
  // Image stamps: frame times on the gyro clock plus the offset; the truth has the frame times.
  std::set<Timestamp> gt;
  for (const auto& p : ds.groundtruth) gt.insert(p.t_ns);
  for (const auto& image : ds.images) {
    const Timestamp t_true = image.t_ns + 25'000'000;
    EXPECT_EQ((t_true - 1'000'000'000) % 50'000'000, 0) << image.t_ns;
    EXPECT_TRUE(gt.count(t_true)) << image.t_ns;
    EXPECT_TRUE(gt.count(image.t_ns)) << image.t_ns;
  }
  // LiDAR: swept, stamped on the gyro clock at the even frames' true times.
  ASSERT_EQ(ds.scans.size(), 3u);
  for (std::size_t i = 0; i < ds.scans.size(); ++i) {
    EXPECT_EQ(ds.scans[i].t_ns, 1'000'000'000 + static_cast<Timestamp>(i) * 100'000'000);
    // float32, as in a LaserScan message (the simulator rounds the LiDAR's values in every format).
    EXPECT_DOUBLE_EQ(ds.scans[i].time_increment_s,
                     static_cast<double>(static_cast<float>(0.1 * 0.5 / 360.0)));
  }
  EXPECT_TRUE(io::lidarTimingNotes(ds).empty());
  // Gyro stamps jittered: not all on the 5 ms grid.
  int off_grid = 0;
  for (const auto& s : ds.imu) off_grid += (s.t_ns - 1'000'000'000) % 5'000'000 != 0 ? 1 : 0;
  EXPECT_GT(off_grid, static_cast<int>(ds.imu.size()) / 2);
}

}  // namespace
}  // namespace ovo::sim
