// LiDAR scale on a synthetic vine slab (a slanted vertical wall 4 m ahead) seen by a pinhole or
// fisheye camera and a planar LiDAR with known extrinsics: the true scale of a unit-scale
// reconstruction is recovered, the extrinsic direction matters, foreground outliers are gated.
#include "estimator/common/lidar_scale.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "camera/kannala_brandt_camera.hpp"
#include "camera/pinhole_radtan_camera.hpp"
#include "common/error.hpp"

namespace ovo::estimator {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kTrueScale = 2.7;  // metric = scale * unit

// Body: x forward, y left, z up. Camera 0.8 m up looking forward (x_C = -y_B, y_C = -z_B,
// z_C = x_B); LiDAR 0.45 m up, 0.1 m left, yawed 10 degrees.
SE3 makeT_B_C() {
  SE3 T = SE3::Identity();
  Mat3 R;
  R.col(0) = Vec3(0, -1, 0);
  R.col(1) = Vec3(0, 0, -1);
  R.col(2) = Vec3(1, 0, 0);
  T.linear() = R;
  T.translation() = Vec3(0.2, 0.0, 0.8);
  return T;
}

SE3 makeT_B_L() {
  SE3 T = SE3::Identity();
  T.linear() = Eigen::AngleAxisd(10.0 * kPi / 180.0, Vec3::UnitZ()).toRotationMatrix();
  T.translation() = Vec3(0.35, 0.1, 0.45);
  return T;
}

// The slab: x_B - 0.25 y_B = 4.
const Vec3 kWallNormal_B(1.0, -0.25, 0.0);
constexpr double kWallOffset = 4.0;

camera::Camera pinhole() {
  return camera::PinholeRadtanCamera(400.0, 400.0, 319.5, 239.5, 640, 480);
}

camera::Camera fisheye() {
  camera::KannalaBrandtParams p;
  p.fx = p.fy = 190.0;
  p.cx = 319.5;
  p.cy = 239.5;
  p.k1 = -0.01;
  p.width = 640;
  p.height = 480;
  return camera::KannalaBrandtCamera(p);
}

// Beams from -90 to 90 degrees every 0.25 degrees, ray cast into the slab, range noise 2 cm.
LidarScan castScan(std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 0.02);
  const SE3 T_B_L = makeT_B_L();
  LidarScan scan;
  scan.angle_min_rad = -kPi / 2.0;
  scan.angle_increment_rad = 0.25 * kPi / 180.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = 30.0;
  for (int i = 0; i <= 720; ++i) {
    const double a = scan.angle_min_rad + i * scan.angle_increment_rad;
    const Vec3 d_B = T_B_L.linear() * Vec3(std::cos(a), std::sin(a), 0.0);
    const Vec3 o_B = T_B_L.translation();
    const double denom = kWallNormal_B.dot(d_B);
    const double r = denom > 1e-6 ? (kWallOffset - kWallNormal_B.dot(o_B)) / denom : -1.0;
    scan.ranges_m.push_back(r > 0.0 && r < scan.range_max_m ? r + noise(rng) : 0.0);
  }
  return scan;
}

// Features on the slab around the scan height: pixel noise 0.3 px, unit-scale points with 1 %
// depth noise.
std::vector<ScaleFeature> slabFeatures(const camera::Camera& cam, int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> lateral(-4.0, 4.0), height(0.05, 0.85);
  std::normal_distribution<double> px_noise(0.0, 0.3), depth_noise(0.0, 0.01);
  const SE3 T_C_B = makeT_B_C().inverse();
  std::vector<ScaleFeature> features;
  for (int attempt = 0; attempt < 100 * n && static_cast<int>(features.size()) < n; ++attempt) {
    const double y = lateral(rng);
    const Vec3 p_B(kWallOffset + 0.25 * y, y, height(rng));
    const Vec3 p_C = T_C_B * p_B;
    const auto px = camera::project(cam, p_C);
    if (!px || !camera::isValid(cam, *px)) continue;
    // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
    const double nv = px_noise(rng), nu = px_noise(rng);
    const double depth_factor = 1.0 + depth_noise(rng);
    features.push_back({*px + Vec2(nu, nv), p_C * depth_factor / kTrueScale});
  }
  return features;
}

TEST(LidarScale, RecoversTrueScaleOnSlabWithPinhole) {
  std::mt19937 rng(1);
  const camera::Camera cam = pinhole();
  const LidarScan scan = castScan(rng);
  const auto features = slabFeatures(cam, 600, rng);
  ASSERT_EQ(features.size(), 600u);
  const SE3 T_C_L = cameraFromLidar(makeT_B_C(), makeT_B_L());
  const auto estimate = estimateLidarScale(scan, T_C_L, cam, features);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_NEAR(estimate->scale, kTrueScale, 0.01 * kTrueScale);
  EXPECT_GE(estimate->associations, 20);
  EXPECT_GT(estimate->spread, 0.0);
  EXPECT_LT(estimate->spread, 0.05 * kTrueScale);
}

TEST(LidarScale, RecoversTrueScaleOnSlabWithFisheye) {
  std::mt19937 rng(2);
  const camera::Camera cam = fisheye();
  const LidarScan scan = castScan(rng);
  const auto features = slabFeatures(cam, 600, rng);
  ASSERT_EQ(features.size(), 600u);
  const auto estimate =
      estimateLidarScale(scan, cameraFromLidar(makeT_B_C(), makeT_B_L()), cam, features);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_NEAR(estimate->scale, kTrueScale, 0.01 * kTrueScale);
  EXPECT_GE(estimate->associations, 20);
}

TEST(LidarScale, InvertedExtrinsicsDoNotGiveTheTrueScale) {
  std::mt19937 rng(3);
  const camera::Camera cam = pinhole();
  const LidarScan scan = castScan(rng);
  const auto features = slabFeatures(cam, 600, rng);
  ASSERT_EQ(features.size(), 600u);
  const SE3 T_C_L = cameraFromLidar(makeT_B_C(), makeT_B_L());
  const auto wrong = estimateLidarScale(scan, T_C_L.inverse(), cam, features);
  if (wrong) {
    EXPECT_GT(std::abs(wrong->scale / kTrueScale - 1.0), 0.1) << wrong->scale;
  }
  // T_B_L^-1 T_B_C (the other composition) is wrong too.
  const auto swapped = estimateLidarScale(scan, makeT_B_L().inverse() * makeT_B_C(), cam, features);
  if (swapped) {
    EXPECT_GT(std::abs(swapped->scale / kTrueScale - 1.0), 0.1) << swapped->scale;
  }
}

TEST(LidarScale, RejectsForegroundCanopyAtDifferentDepth) {
  std::mt19937 rng(4);
  const camera::Camera cam = pinhole();
  const LidarScan scan = castScan(rng);
  auto features = slabFeatures(cam, 600, rng);
  ASSERT_EQ(features.size(), 600u);
  const SE3 T_C_L = cameraFromLidar(makeT_B_C(), makeT_B_L());
  const auto clean = estimateLidarScale(scan, T_C_L, cam, features);
  ASSERT_TRUE(clean.has_value());

  // Leaves at 55 % of the slab's range on the rays of every 15th beam: the same pixel as the
  // LiDAR point (the camera looks over the scan plane), so they associate, but at the wrong depth.
  int leaves = 0;
  for (std::size_t b = 0; b < scan.ranges_m.size(); b += 15) {
    if (!scan.valid(b)) continue;
    const Vec3 p_C = T_C_L * scan.point_L(b);
    const auto px = camera::project(cam, p_C);
    if (!px || !camera::isValid(cam, *px)) continue;
    features.push_back({*px + Vec2(0.5, -0.5), 0.55 * p_C / kTrueScale});
    ++leaves;
  }
  ASSERT_GE(leaves, 8);
  const auto estimate = estimateLidarScale(scan, T_C_L, cam, features);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_NEAR(estimate->scale, kTrueScale, 0.01 * kTrueScale);
  EXPECT_GE(estimate->rejected, leaves * 8 / 10);
  EXPECT_LT(estimate->associations, clean->associations + 3);

  // Without the gate the leaves pull the scale up (the test's outliers matter).
  LidarScaleOptions no_gate;
  no_gate.gate_relative = 10.0;
  no_gate.huber_k = 100.0;
  const auto ungated = estimateLidarScale(scan, T_C_L, cam, features, no_gate);
  ASSERT_TRUE(ungated.has_value());
  EXPECT_GT(ungated->scale, 1.05 * kTrueScale);
}

TEST(LidarScale, TooFewAssociationsGiveNothing) {
  std::mt19937 rng(5);
  const camera::Camera cam = pinhole();
  const LidarScan scan = castScan(rng);
  const SE3 T_C_L = cameraFromLidar(makeT_B_C(), makeT_B_L());
  // Four features exactly on scan points: one short of the default five.
  std::vector<ScaleFeature> features;
  for (std::size_t b = 300; b < 420 && features.size() < 4; b += 30) {
    ASSERT_TRUE(scan.valid(b));
    const Vec3 p_C = T_C_L * scan.point_L(b);
    const auto px = camera::project(cam, p_C);
    ASSERT_TRUE(px && camera::isValid(cam, *px));
    features.push_back({*px, p_C / kTrueScale});
  }
  EXPECT_FALSE(estimateLidarScale(scan, T_C_L, cam, features).has_value());
  LidarScaleOptions four;
  four.min_associations = 4;
  const auto estimate = estimateLidarScale(scan, T_C_L, cam, features, four);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_NEAR(estimate->scale, kTrueScale, 1e-9);
  EXPECT_FALSE(estimateLidarScale(scan, T_C_L, cam, {}).has_value());
  LidarScan empty = scan;
  for (double& r : empty.ranges_m) r = std::nan("");
  EXPECT_FALSE(estimateLidarScale(empty, T_C_L, cam, features, four).has_value());
}

TEST(LidarScale, ReadsOptionsAndRejectsOutOfRange) {
  const Config c = Config::fromString(
      "kf:\n  lidar_scale:\n    association_radius_px: 4.5\n    min_associations: 8\n");
  const LidarScaleOptions o = readLidarScaleOptions(c);
  EXPECT_DOUBLE_EQ(o.association_radius_px, 4.5);
  EXPECT_EQ(o.min_associations, 8);
  EXPECT_DOUBLE_EQ(o.gate_relative, LidarScaleOptions{}.gate_relative);
  EXPECT_NO_THROW(c.checkAllUsed());
  EXPECT_THROW(
      readLidarScaleOptions(Config::fromString("kf:\n  lidar_scale:\n    gate_relative: 0\n")),
      Error);
}

}  // namespace
}  // namespace ovo::estimator
