// The scale the LiDAR gives the window (WindowLidar::scaleRatio): at the right scale the ranges
// agree with the landmarks; at a wrong one the ranges read where the landmarks' points cross the
// scan plane are those of the wrong landmarks, and disagree among themselves instead of agreeing
// on the wrong ratio, so the disagreement alone used to say nothing and the gates then rejected
// every range that would have corrected the scale. The scale at which the scan agrees with the
// map is found instead.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>

#include "camera/pinhole_radtan_camera.hpp"
#include "estimator/window/lidar_ranges.hpp"

namespace ovo::estimator {
namespace {

constexpr double kWallX = 4.0;  // a wall across the drive, m ahead of the first keyframe

// A camera 0.3 m above a LiDAR whose scan plane is the body's xy plane, looking along body x.
SensorSetup rig() {
  SensorSetup s{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)};
  s.T_B_C.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  s.T_B_C.translation() = Vec3(0.0, 0.0, 0.3);
  s.has_lidar = true;
  return s;
}

// The scan of the wall from a LiDAR at x: r = (wall - x) / cos(phi) over +-40 deg.
LidarScan wallScan(double x) {
  LidarScan scan;
  scan.angle_increment_rad = 0.5 * M_PI / 180.0;
  scan.angle_min_rad = -40.0 * M_PI / 180.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = 30.0;
  for (int i = 0; i <= 160; ++i)
    scan.ranges_m.push_back((kWallX - x) / std::cos(scan.angle_min_rad + i * scan.angle_increment_rad));
  return scan;
}

// Three keyframes 0.3 m apart towards the wall, each with its scan, and 13 landmarks on the wall
// in the scan plane, anchored in the first: the window as it is (scale 1) or at `scale` times
// the true distances (camera baselines and depths; the camera's mount stays metric).
WindowMap wallWindow(const SensorSetup& setup, double scale) {
  WindowMap map;
  for (int k = 0; k < 3; ++k) {
    auto kf = std::make_unique<Keyframe>(SE3::Identity());
    kf->id = k;
    SE3 T = SE3::Identity();
    T.translation() = Vec3(0.3 * k * scale, 0.0, 0.0);
    kf->setPose(T);
    kf->scan = wallScan(0.3 * k);
    map.keyframes.push_back(std::move(kf));
  }
  for (int i = 0; i < 13; ++i) {
    const Vec3 p_W(kWallX, -1.5 + 0.25 * i, 0.0);
    const TrackId id = 100 + i;
    for (int k = 0; k < 3; ++k) {
      SE3 T_true = SE3::Identity();
      T_true.translation() = Vec3(0.3 * k, 0.0, 0.0);
      TrackObservation o;
      o.track_id = id;
      o.bearing_C = ((T_true * setup.T_B_C).inverse() * p_W).normalized();
      map.keyframes[k]->observations[id] = o;
    }
    Landmark lm;
    lm.id = id;
    lm.anchor_kf = 0;
    lm.bearing_anchor_C = map.keyframes[0]->observations.at(id).bearing_C;
    lm.rho[0] = 1.0 / (scale * (setup.T_B_C.inverse() * p_W).norm());
    map.landmarks[id] = lm;
  }
  return map;
}

TEST(LidarScaleRatio, RangesThatAgreeWithTheWindowConfirmItsScale) {
  const SensorSetup setup = rig();
  const WindowOptions options;
  const WindowLidar lidar(setup, options);
  const auto ratio = lidar.scaleRatio(wallWindow(setup, 1.0));
  ASSERT_TRUE(ratio);
  EXPECT_NEAR(*ratio, 1.0, 1e-3);
}

TEST(LidarScaleRatio, AWindowAtTwiceOrHalfTheScaleIsFoundThoughItsRangesDisagree) {
  const SensorSetup setup = rig();
  const WindowOptions options;
  const WindowLidar lidar(setup, options);
  for (const double scale : {2.0, 0.5, 1.6}) {
    const WindowMap map = wallWindow(setup, scale);
    // At the wrong scale the wall's points lie off the scan plane (the camera sits 0.3 m above
    // it): the ranges read at them are too few to agree on anything.
    int in_plane = 0;
    for (const auto& kf : map.keyframes) in_plane += lidar.rangesAt(*kf, map).size();
    EXPECT_LT(in_plane, options.lidar_rescale_min_ranges) << "scale " << scale;
    const auto ratio = lidar.scaleRatio(map);
    ASSERT_TRUE(ratio) << "scale " << scale;
    EXPECT_NEAR(*ratio, scale, 0.02 * scale);
  }
}

TEST(LidarScaleRatio, AMapThatAgreesWithTheScanAtNoScaleGivesNone) {
  const SensorSetup setup = rig();
  const WindowOptions options;
  const WindowLidar lidar(setup, options);
  WindowMap map = wallWindow(setup, 1.0);
  // Each landmark at its own scale: no one scale brings more than a few onto the wall.
  int i = 0;
  for (auto& [id, lm] : map.landmarks) lm.rho[0] /= 0.3 + 0.27 * (i++);
  EXPECT_FALSE(lidar.scaleRatio(map));
}

}  // namespace
}  // namespace ovo::estimator
