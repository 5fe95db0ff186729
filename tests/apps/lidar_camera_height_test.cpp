// `ovo run`'s camera height from the LiDAR (cameraHeightFromScans): taken only when the rig gives
// none, from the simulator's scans of the default scenario, and said in a note.
#include <gtest/gtest.h>

#include "apps/offline_runner.hpp"
#include "common/config.hpp"
#include "sim/simulation.hpp"
#include "tests/test_support.hpp"

namespace ovo::app {
namespace {

struct SimRig {
  io::Dataset data;
  estimator::SensorSetup setup{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)};
  double camera_height_m = 0.0;
};

SimRig simulatedRig() {
  Config cfg = Config::load(test::sourcePath("configs/sim/vineyard_row.yaml"));
  cfg.applyOverrides({"duration_s=6"});
  const sim::Simulation sim(sim::readScenario(cfg));
  SimRig r;
  r.data.scans = sim.lidar();
  r.setup.T_B_C = sim.T_B_C();
  r.setup.T_B_L = sim.T_B_L();
  r.setup.has_lidar = true;
  r.camera_height_m = sim.cameraHeightM();
  return r;
}

TEST(LidarCameraHeight, ARigWithoutACameraHeightTakesTheLidarsAndSaysSo) {
  SimRig r = simulatedRig();
  const auto note = cameraHeightFromScans(r.data, &r.setup);
  ASSERT_TRUE(note.has_value());
  ASSERT_TRUE(r.setup.camera_height_m.has_value());
  EXPECT_NEAR(*r.setup.camera_height_m, r.camera_height_m, 0.005);
  EXPECT_NE(note->find("measured from the LiDAR's ground hits"), std::string::npos) << *note;
  EXPECT_NE(note->find("the rig gives none"), std::string::npos) << *note;
}

TEST(LidarCameraHeight, TheRigsCameraHeightStandsAndNoScansGiveNothing) {
  SimRig r = simulatedRig();
  r.setup.camera_height_m = 1.2;
  EXPECT_FALSE(cameraHeightFromScans(r.data, &r.setup).has_value());
  EXPECT_DOUBLE_EQ(*r.setup.camera_height_m, 1.2);
  r.setup.camera_height_m.reset();
  r.data.scans.clear();
  EXPECT_FALSE(cameraHeightFromScans(r.data, &r.setup).has_value());
  EXPECT_FALSE(r.setup.camera_height_m.has_value());
}

}  // namespace
}  // namespace ovo::app
