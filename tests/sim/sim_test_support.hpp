// Scenarios for the simulator tests: the defaults with the repository's RoMoVi calibration, noise
// switched off where a test needs exact values.
#pragma once

#include <opencv2/core.hpp>
#include <optional>

#include "common/types.hpp"
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

/// Centroid of |a - b| within `radius` pixels of `around` (a marker rendered white in one image
/// and black in the other: the marker's coverage alone); nullopt when the images agree there.
inline std::optional<Vec2> diffCentroid(const cv::Mat& a, const cv::Mat& b, const Vec2& around,
                                        int radius) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  diff.convertTo(diff, CV_64F);
  double sum = 0.0, su = 0.0, sv = 0.0;
  for (int v = std::max(0, int(around.y()) - radius);
       v <= std::min(diff.rows - 1, int(around.y()) + radius); ++v)
    for (int u = std::max(0, int(around.x()) - radius);
         u <= std::min(diff.cols - 1, int(around.x()) + radius); ++u) {
      const double w = diff.at<double>(v, u);
      sum += w;
      su += w * u;
      sv += w * v;
    }
  if (sum < 1.0) return std::nullopt;
  return Vec2(su / sum, sv / sum);
}

}  // namespace ovo::sim::test
