#include "factors/terrain_plane_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

// A hillside z = 0.08 x - 0.03 y + 0.2 (8 % grade along x, 3 % across), normal up.
const std::vector<double> kHill = {0.08, -0.03, 0.2};

Vec3 onHill(double x, double y) { return Vec3(x, y, kHill[0] * x + kHill[1] * y + kHill[2]); }

TEST(Terrain, HeightIsAlongTheUnitNormalAndPositiveAbove) {
  EXPECT_NEAR(heightOverTerrain(onHill(3.0, -2.0), kHill.data()), 0.0, 1e-12);
  // 1 m straight up is cos(tilt) m along the normal.
  const double cos_tilt = 1.0 / std::sqrt(1.0 + 0.08 * 0.08 + 0.03 * 0.03);
  EXPECT_NEAR(heightOverTerrain(onHill(3.0, -2.0) + Vec3::UnitZ(), kHill.data()), cos_tilt, 1e-12);
  EXPECT_LT(heightOverTerrain(onHill(3.0, -2.0) - Vec3::UnitZ(), kHill.data()), 0.0);
}

TEST(Terrain, TheGroundBelowARobotOnTheHillIsTheHill) {
  // The body stands on the hill (z along its normal) 0.3 m above it; the camera 0.7 m above the
  // body and 0.35 m ahead: 1 m above the ground along the normal.
  const Vec3 n = Vec3(-kHill[0], -kHill[1], 1.0).normalized();
  SE3 T_W_B = SE3::Identity();
  T_W_B.linear() = Quat::FromTwoVectors(Vec3::UnitZ(), n).toRotationMatrix() *
                   Eigen::AngleAxisd(0.7, Vec3::UnitZ()).toRotationMatrix();
  T_W_B.translation() = onHill(4.0, 1.0) + 0.3 * n;
  SE3 T_B_C = SE3::Identity();
  T_B_C.translation() = Vec3(0.35, 0.0, 0.7);
  double g[3];
  terrainBelow(T_W_B, T_B_C, 1.0, g);
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(g[k], kHill[k], 1e-12);
}

TEST(Terrain, ScalingKeepsScaledPointsOnThePlane) {
  const Vec3 centre(1.0, -0.5, 0.7);
  const double s = 1.3;
  double g[3] = {kHill[0], kHill[1], kHill[2]};
  scaleTerrain(g, centre, s);
  for (const Vec3& p : {onHill(0.0, 0.0), onHill(5.0, 2.0), onHill(-3.0, 7.0)})
    EXPECT_NEAR(heightOverTerrain(centre + s * (p - centre), g), 0.0, 1e-12);
}

TEST(TerrainPointFactor, ZeroForAGroundPointAndItsHeightOverSigmaOtherwise) {
  std::mt19937 rng(5);
  const SE3 T_B_C = testing::randomPose(rng, 1.0, 0.5);
  const SE3 T_W_B = testing::randomPose(rng, 0.3, 3.0);
  const Vec3 p_W = onHill(2.0, 1.0);
  const Vec3 p_C = (T_W_B * T_B_C).inverse() * p_W;
  const TerrainPointFactor f(p_C.normalized(), T_B_C, 0.05);
  const auto q = testing::quatBlock(Quat(T_W_B.linear()));
  const auto p = testing::vecBlock(T_W_B.translation());
  EXPECT_NEAR(testing::evaluate(f, {q, p, {1.0 / p_C.norm()}, kHill})[0], 0.0, 1e-9);
  // The plane 0.1 m lower along z: the point is 0.1 cos(tilt) m above it, 2 sigmas.
  const std::vector<double> lower = {kHill[0], kHill[1], kHill[2] - 0.1};
  const double cos_tilt = 1.0 / std::sqrt(1.0 + 0.08 * 0.08 + 0.03 * 0.03);
  EXPECT_NEAR(testing::evaluate(f, {q, p, {1.0 / p_C.norm()}, lower})[0], 2.0 * cos_tilt, 1e-9);
  EXPECT_EQ(testing::evaluate(f, {q, p, {0.0}, kHill}).size(), 0);
}

TEST(TerrainPointFactor, JacobiansMatchNumeric) {
  std::mt19937 rng(6);
  for (int trial = 0; trial < 8; ++trial) {
    const SE3 T_B_C = testing::randomPose(rng, 1.0, 0.5);
    const SE3 T_W_B = testing::randomPose(rng);
    const Vec3 b = testing::randomVec(rng).normalized();
    const TerrainPointFactor f(b, T_B_C, 0.05);
    const std::vector<double> g = {0.3 * (trial - 4) / 4.0, -0.1 * trial / 8.0, 0.5};
    testing::expectJacobiansMatch(f,
                                  {testing::quatBlock(Quat(T_W_B.linear())),
                                   testing::vecBlock(T_W_B.translation()),
                                   {0.1 + 0.2 * trial},
                                   g},
                                  {true, false, false, false}, 1e-5);
  }
}

TEST(TerrainWalkFactor, SameTerrainIsFreeAndAHeightStepCostsItsWalk) {
  const Vec3 mid(30.0, -12.0, 2.0);
  const TerrainWalkFactor f(mid, 4.0, 0.01, 0.02);  // over 4 m: 0.02 slope, 0.04 m
  EXPECT_NEAR(testing::evaluate(f, {kHill, kHill}).norm(), 0.0, 1e-12);
  // The same plane written about another origin: tilted by 0.02 about the midpoint, it has the
  // same height there, so only the slope step counts (1 sigma), not the offset c far from W's
  // origin.
  std::vector<double> tilted = kHill;
  tilted[0] += 0.02;
  tilted[2] -= 0.02 * mid.x();
  const Eigen::VectorXd r = testing::evaluate(f, {kHill, tilted});
  EXPECT_NEAR(r[0], 1.0, 1e-9);
  EXPECT_NEAR(r[1], 0.0, 1e-12);
  EXPECT_NEAR(r[2], 0.0, 1e-9);
  std::vector<double> raised = kHill;
  raised[2] += 0.04;
  EXPECT_NEAR(testing::evaluate(f, {kHill, raised})[2], 1.0, 1e-9);
  testing::expectJacobiansMatch(f, {kHill, tilted}, {false, false});
}

}  // namespace
}  // namespace ovo::factors
