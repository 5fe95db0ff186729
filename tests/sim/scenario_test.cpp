#include "sim/scenario.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "common/config.hpp"
#include "common/error.hpp"
#include "sim/board_scene.hpp"
#include "sim/simulation.hpp"
#include "tests/sim/sim_test_support.hpp"

namespace ovo::sim {
namespace {

std::string errorOf(const std::string& yaml) {
  try {
    readScenario(Config::fromString(yaml, "scenario.yaml"));
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(Scenario, UnknownKeyIsAnErrorNamingTheKeyAndLine) {
  const std::string msg = errorOf("camera:\n  model: pinhole\nworld:\n  row_spacing: 2.5\n");
  EXPECT_NE(msg.find("world.row_spacing"), std::string::npos) << msg;
  EXPECT_NE(msg.find("scenario.yaml:4"), std::string::npos) << msg;
}

TEST(Scenario, OutOfRangeValueNamesTheKey) {
  const std::string msg = errorOf("camera:\n  model: pinhole\nworld:\n  grade_pct: 120\n");
  EXPECT_NE(msg.find("world.grade_pct"), std::string::npos) << msg;
}

// Values in range that still make no sequence: an interrow outside the field (the robot drove
// 376 m away), a start time whose stamps overflow 2^63 (they turned negative).
TEST(Scenario, InterrowOutsideTheFieldAndOverflowingStartAreErrors) {
  std::string msg = errorOf(
      "camera:\n  model: pinhole\nworld:\n  num_rows: 1\ntrajectory:\n  first_interrow: 150\n");
  EXPECT_NE(msg.find("'trajectory.first_interrow': 150 is no interrow of a 1-row world"),
            std::string::npos)
      << msg;
  msg = errorOf("camera:\n  model: pinhole\nstart_time_ns: 9223372036854775807\n");
  EXPECT_NE(msg.find("scenario.yaml:3: key 'start_time_ns': expected an integer in [0, "
                     "4000000000000000000]"),
            std::string::npos)
      << msg;
  EXPECT_EQ(errorOf("camera:\n  model: pinhole\nworld:\n  num_rows: 6\ntrajectory:\n  "
                    "first_interrow: 4\n"),
            "");
}

TEST(Scenario, NegativeSeedNamesWhereItWasGiven) {
  EXPECT_NE(errorOf("camera:\n  model: pinhole\nseed: -1\n").find("scenario.yaml:3: key 'seed'"),
            std::string::npos);
  Config c = Config::fromString("camera:\n  model: pinhole\nseed: 4\n", "scenario.yaml");
  c.applyOverride("seed=-1");  // the file's value is fine: the error names the --set
  try {
    readScenario(c);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--set seed: key 'seed': expected an integer in [0, "),
              std::string::npos)
        << e.what();
  }
}

TEST(Scenario, LidarRateMustDivideCameraRate) {
  const std::string msg =
      errorOf("camera:\n  model: pinhole\n  rate_hz: 20\nlidar:\n  rate_hz: 7\n");
  EXPECT_NE(msg.find("lidar.rate_hz"), std::string::npos) << msg;
}

TEST(Scenario, MissingCalibrationFileIsAnError) {
  const std::string msg = errorOf("camera:\n  calibration: no/such/calib_results.txt\n");
  EXPECT_NE(msg.find("camera.calibration"), std::string::npos) << msg;
}

TEST(Scenario, EveryShippedScenarioLoadsAndBuilds) {
  int count = 0;
  for (const auto& entry :
       std::filesystem::directory_iterator(::ovo::test::sourcePath("configs/sim"))) {
    if (entry.path().extension() != ".yaml") continue;
    SCOPED_TRACE(entry.path().string());
    const Config config = Config::load(entry.path());
    if (isBoardScene(config)) {  // checkerboard.yaml: sim/board_scene, not a vineyard run
      EXPECT_GT(readBoardScene(config).views, 0);
      continue;
    }
    const Scenario s = readScenario(config);
    const Simulation sim(s);
    EXPECT_GT(sim.frameCount(), 20);
    EXPECT_GT(sim.trajectory().duration(), 1.0);
    ++count;
  }
  EXPECT_GE(count, 6);
}

TEST(Scenario, WrittenScenarioReadsBackTheSame) {
  Scenario s = test::defaultScenario();
  s.seed = 77;
  s.world.grade_pct = 25.0;
  s.trajectory.kind = "spin";
  s.lidar.mount.pitch_down_deg = 5.0;
  const Scenario back = readScenario(Config::fromString(scenarioYaml(s), "written.yaml"));
  EXPECT_EQ(back.seed, 77u);
  EXPECT_EQ(back.world.grade_pct, 25.0);
  EXPECT_EQ(back.trajectory.kind, "spin");
  EXPECT_EQ(back.lidar.mount.pitch_down_deg, 5.0);
  EXPECT_EQ(back.camera.calibration, s.camera.calibration);
  EXPECT_EQ(scenarioYaml(back), scenarioYaml(s));
}

TEST(Scenario, RealitiesReadBackAndAreWrittenOnlyWhenOn) {
  Scenario s = test::defaultScenario();
  const std::string plain = scenarioYaml(s);
  for (const char* key :
       {"time_offset_s", "rolling_shutter_s", "frame_drop_probability", "auto_exposure",
        "time_jitter_s", "sweep", "scan_time_s", "ground_roughness_m", "wind_amplitude_m", "rig:"})
    EXPECT_EQ(plain.find(key), std::string::npos) << key;  // the bytes of older scenarios
  s.camera.time_offset_s = -0.04;
  s.camera.rolling_shutter_s = 0.025;
  s.camera.frame_drop_probability = 0.01;
  s.camera.auto_exposure = true;
  s.camera.auto_exposure_step = 0.2;
  s.camera.auto_exposure_rate_hz = 3.0;
  s.imu.time_jitter_s = 0.0005;
  s.lidar.sweep = true;
  s.lidar.scan_time_s = 0.05;
  s.world.ground_roughness_m = 0.02;
  s.world.ground_wavelength_m = 1.5;
  s.world.wind_amplitude_m = 0.03;
  s.world.wind_period_s = 2.5;
  s.rig.camera_time_offset_s = 0.01;
  const Scenario back = readScenario(Config::fromString(scenarioYaml(s), "written.yaml"));
  EXPECT_EQ(back.camera.time_offset_s, -0.04);
  EXPECT_EQ(back.camera.rolling_shutter_s, 0.025);
  EXPECT_EQ(back.camera.frame_drop_probability, 0.01);
  EXPECT_TRUE(back.camera.auto_exposure);
  EXPECT_EQ(back.camera.auto_exposure_step, 0.2);
  EXPECT_EQ(back.camera.auto_exposure_rate_hz, 3.0);
  EXPECT_EQ(back.imu.time_jitter_s, 0.0005);
  EXPECT_TRUE(back.lidar.sweep);
  EXPECT_EQ(back.lidar.scan_time_s, 0.05);
  EXPECT_EQ(back.world.ground_roughness_m, 0.02);
  EXPECT_EQ(back.world.ground_wavelength_m, 1.5);
  EXPECT_EQ(back.world.wind_amplitude_m, 0.03);
  EXPECT_EQ(back.world.wind_period_s, 2.5);
  EXPECT_EQ(back.rig.camera_time_offset_s, 0.01);
  EXPECT_EQ(scenarioYaml(back), scenarioYaml(s));
}

TEST(Scenario, RealitiesThatMakeNoSensorAreErrorsNamingTheKey) {
  const std::string base = "camera:\n  model: pinhole\n";
  EXPECT_NE(errorOf(base + "  rolling_shutter_s: 0.05\n").find("camera.rolling_shutter_s"),
            std::string::npos);  // a frame period at 20 Hz
  EXPECT_NE(errorOf(base + "  time_offset_s: 0.6\n").find("camera.time_offset_s"),
            std::string::npos);
  EXPECT_NE(errorOf(base + "lidar:\n  scan_time_s: 0.05\n").find("lidar.sweep is false"),
            std::string::npos);
  EXPECT_NE(errorOf(base + "lidar:\n  sweep: true\n  scan_time_s: 0.2\n")
                .find("lidar.scan_time_s (0.2 s) must be at most the scan period"),
            std::string::npos);
  EXPECT_NE(errorOf(base + "imu:\n  time_jitter_s: 0.001\n").find("imu.time_jitter_s"),
            std::string::npos);
  EXPECT_NE(errorOf(base + "world:\n  ground_roughness_m: 0.2\n  ground_wavelength_m: 1.0\n")
                .find("world.ground_roughness_m"),
            std::string::npos);
  EXPECT_EQ(errorOf(base + "  rolling_shutter_s: 0.03\n  time_offset_s: -0.05\nlidar:\n  "
                           "sweep: true\n  scan_time_s: 0.1\nimu:\n  time_jitter_s: 0.0005\n"),
            "");
}

TEST(Scenario, CameraMountLooksForwardAndDown) {
  MountOptions m;
  m.pitch_down_deg = 10.0;
  const SE3 T_B_C = cameraMountTransform(m);
  const Vec3 z_C_in_B = T_B_C.linear().col(2);                       // optical axis
  EXPECT_GT(z_C_in_B.x(), 0.98);                                     // forward
  EXPECT_NEAR(z_C_in_B.z(), -std::sin(10.0 * M_PI / 180.0), 1e-12);  // down
  EXPECT_NEAR(T_B_C.linear().col(0).y(), -1.0, 1e-12);               // camera x = right = -y_B
}

}  // namespace
}  // namespace ovo::sim
