#include <gtest/gtest.h>

#include "factors/lidar_range_factor.hpp"
#include "factors/pose_prior_factor.hpp"
#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;
using testing::vecBlock;

struct RangeScene {
  SE3 T_W_Ba, T_W_Bk, T_B_C, T_B_L;
  Vec3 bearing_Ca;
  double rho;
  double range_true;  // LiDAR origin of keyframe k to the landmark (m)
};

RangeScene randomRangeScene(std::mt19937& rng, double depth_m) {
  RangeScene s;
  s.T_B_C = testing::randomPose(rng, 1.0, 0.2);
  s.T_B_L = testing::randomPose(rng, 1.0, 0.3);
  s.T_W_Ba = testing::randomPose(rng);
  s.T_W_Bk = testing::randomPose(rng, 3.0, 0.5);
  s.bearing_Ca = testing::randomVec(rng).normalized();
  s.rho = 1.0 / depth_m;
  const Vec3 p_W = s.T_W_Ba * s.T_B_C * (depth_m * s.bearing_Ca);
  s.range_true = ((s.T_W_Bk * s.T_B_L).inverse() * p_W).norm();
  return s;
}

std::vector<std::vector<double>> blocksOf(const RangeScene& s) {
  return {quatBlock(Quat(s.T_W_Ba.rotation())),
          vecBlock(s.T_W_Ba.translation()),
          quatBlock(Quat(s.T_W_Bk.rotation())),
          vecBlock(s.T_W_Bk.translation()),
          {s.rho}};
}

TEST(LidarRangeFactor, ZeroAtTrueRangeAndSignedWhenRangeIsLonger) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    const RangeScene s = randomRangeScene(rng, 2.0 + trial);
    const double sigma = 0.05;
    const LidarRangeFactor exact(s.bearing_Ca, s.range_true, s.T_B_C, s.T_B_L, sigma);
    EXPECT_NEAR(testing::evaluate(exact, blocksOf(s))[0], 0.0, 1e-9);
    // The LiDAR measures 0.2 m more than the landmark's distance: residual = -0.2 / sigma.
    const LidarRangeFactor longer(s.bearing_Ca, s.range_true + 0.2, s.T_B_C, s.T_B_L, sigma);
    EXPECT_NEAR(testing::evaluate(longer, blocksOf(s))[0], -0.2 / sigma, 1e-8);
  }
}

TEST(LidarRangeFactor, JacobiansMatchNumeric) {
  std::mt19937 rng(12);
  for (const double depth : {1.0, 5.0, 30.0}) {
    const RangeScene s = randomRangeScene(rng, depth);
    const LidarRangeFactor f(s.bearing_Ca, s.range_true + 0.3, s.T_B_C, s.T_B_L, 0.03);
    testing::expectJacobiansMatch(f, blocksOf(s), {true, false, true, false, false}, 1e-6);
  }
}

TEST(LidarRangeFactor, RejectsNonPositiveInverseDepth) {
  std::mt19937 rng(13);
  RangeScene s = randomRangeScene(rng, 3.0);
  const LidarRangeFactor f(s.bearing_Ca, 3.0, s.T_B_C, s.T_B_L, 0.03);
  s.rho = 0.0;
  EXPECT_EQ(testing::evaluate(f, blocksOf(s)).size(), 0);
  s.rho = -0.1;
  EXPECT_EQ(testing::evaluate(f, blocksOf(s)).size(), 0);
}

TEST(LidarRangeAnchorFactor, AgreesWithGeneralFactorWhenScanIsAtAnchor) {
  std::mt19937 rng(14);
  for (int trial = 0; trial < 5; ++trial) {
    RangeScene s = randomRangeScene(rng, 4.0);
    s.T_W_Bk = s.T_W_Ba;
    const double range = 3.7;
    const LidarRangeFactor general(s.bearing_Ca, range, s.T_B_C, s.T_B_L, 0.05);
    const LidarRangeAnchorFactor anchor(s.bearing_Ca, range, s.T_B_C, s.T_B_L, 0.05);
    const double r_general = testing::evaluate(general, blocksOf(s))[0];
    EXPECT_NEAR(testing::evaluate(anchor, {{s.rho}})[0], r_general, 1e-9);
    testing::expectJacobiansMatch(anchor, {{s.rho}}, {false}, 1e-6);
  }
}

TEST(LidarRangeFactor, PlanarMeasuresTheDistanceInTheScanPlane) {
  std::mt19937 rng(16);
  for (int trial = 0; trial < 5; ++trial) {
    const RangeScene s = randomRangeScene(rng, 3.0 + trial);
    const Vec3 p_L = (s.T_W_Bk * s.T_B_L).inverse() * (s.T_W_Ba * s.T_B_C * (s.bearing_Ca / s.rho));
    const double in_plane = p_L.head<2>().norm();
    const double sigma = 0.05;
    const LidarRangeFactor planar(s.bearing_Ca, in_plane + 0.1, s.T_B_C, s.T_B_L, sigma, true);
    EXPECT_NEAR(testing::evaluate(planar, blocksOf(s))[0], -0.1 / sigma, 1e-8);
    testing::expectJacobiansMatch(planar, blocksOf(s), {true, false, true, false, false}, 1e-6);
    RangeScene at_anchor = s;
    at_anchor.T_W_Bk = s.T_W_Ba;
    const LidarRangeFactor general(s.bearing_Ca, 2.5, s.T_B_C, s.T_B_L, sigma, true);
    const LidarRangeAnchorFactor anchor(s.bearing_Ca, 2.5, s.T_B_C, s.T_B_L, sigma, true);
    EXPECT_NEAR(testing::evaluate(anchor, {{s.rho}})[0],
                testing::evaluate(general, blocksOf(at_anchor))[0], 1e-9);
    testing::expectJacobiansMatch(anchor, {{s.rho}}, {false}, 1e-6);
  }
}

TEST(LidarRangeFactor, OnAGroundBeamMeasuresTheHeightOffThePlaneThroughItsEnd) {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 5; ++trial) {
    const RangeScene s = randomRangeScene(rng, 3.0 + trial);
    const Vec3 p_L = (s.T_W_Bk * s.T_B_L).inverse() * (s.T_W_Ba * s.T_B_C * (s.bearing_Ca / s.rho));
    const Vec3 up_L = testing::randomVec(rng).normalized();
    // The beam ended on a plane 0.04 m below the landmark: residual +0.04 / sigma.
    const double h = up_L.dot(p_L) - 0.04;
    const double sigma = 0.02;
    const LidarRangeFactor ground(s.bearing_Ca, h, s.T_B_C, s.T_B_L, sigma, true, up_L);
    EXPECT_NEAR(testing::evaluate(ground, blocksOf(s))[0], 0.04 / sigma, 1e-8);
    testing::expectJacobiansMatch(ground, blocksOf(s), {true, false, true, false, false}, 1e-6);
    RangeScene at_anchor = s;
    at_anchor.T_W_Bk = s.T_W_Ba;
    const LidarRangeFactor general(s.bearing_Ca, -0.6, s.T_B_C, s.T_B_L, sigma, false, up_L);
    const LidarRangeAnchorFactor anchor(s.bearing_Ca, -0.6, s.T_B_C, s.T_B_L, sigma, false, up_L);
    EXPECT_NEAR(testing::evaluate(anchor, {{s.rho}})[0],
                testing::evaluate(general, blocksOf(at_anchor))[0], 1e-9);
    testing::expectJacobiansMatch(anchor, {{s.rho}}, {false}, 1e-6);
  }
}

TEST(PosePriorFactor, ZeroAtPriorAndJacobiansMatchNumeric) {
  std::mt19937 rng(15);
  const SE3 T0 = testing::randomPose(rng);
  Mat6 A = Mat6::Random();
  const Mat6 info = A * A.transpose() + Mat6::Identity();
  const PosePriorFactor f(T0, info);
  EXPECT_LT(
      testing::evaluate(f, {quatBlock(Quat(T0.rotation())), vecBlock(T0.translation())}).norm(),
      1e-12);
  for (int trial = 0; trial < 5; ++trial) {
    const SE3 T = T0 * testing::randomPose(rng, 1.0, 0.5);
    const std::vector<std::vector<double>> blocks = {quatBlock(Quat(T.rotation())),
                                                     vecBlock(T.translation())};
    testing::expectJacobiansMatch(f, blocks, {true, false}, 1e-6);
    // The whitened squared norm is the Mahalanobis distance of [Log(R R0^T); p - p0].
    Eigen::Matrix<double, 6, 1> e;
    e << so3::log(T.rotation() * T0.rotation().transpose()), T.translation() - T0.translation();
    EXPECT_NEAR(testing::evaluate(f, blocks).squaredNorm(), e.dot(info * e),
                1e-8 * e.dot(info * e));
  }
}

TEST(PosePriorFactor, GaugePriorLeavesRollAndPitchFree) {
  std::mt19937 rng(16);
  const SE3 T0 = testing::randomPose(rng);
  const PosePriorFactor f(T0, PosePriorFactor::gaugeInformation(0.01, 0.01));
  // Rotating about a horizontal world axis costs nothing; about the vertical it does.
  const Quat tilted =
      Quat(Eigen::AngleAxisd(0.2, Vec3(1, 1, 0).normalized())) * Quat(T0.rotation());
  const Quat yawed = Quat(Eigen::AngleAxisd(0.2, Vec3::UnitZ())) * Quat(T0.rotation());
  const auto p0 = vecBlock(T0.translation());
  EXPECT_LT(testing::evaluate(f, {quatBlock(tilted), p0}).norm(), 1e-9);
  EXPECT_NEAR(testing::evaluate(f, {quatBlock(yawed), p0}).norm(), 0.2 / 0.01, 1e-6);
}

}  // namespace
}  // namespace ovo::factors
