// Scenarios for the simulator tests: the defaults with the repository's RoMoVi calibration, noise
// switched off where a test needs exact values.
#pragma once

#include "sim/scenario.hpp"
#include "tests/test_support.hpp"

namespace ovo::sim::test {

inline Scenario defaultScenario() {
  Scenario s;
  s.name = "test";
  s.camera.calibration = ::ovo::test::sourcePath("configs/cameras/romovi_ocam.txt");
  return s;
}

/// No image noise, exposure changes, IMU or LiDAR noise.
inline Scenario exactScenario() {
  Scenario s = defaultScenario();
  s.nuisance.image_noise = false;
  s.nuisance.exposure_changes = false;
  s.imu.noise = false;
  s.lidar.noise = false;
  return s;
}

}  // namespace ovo::sim::test
