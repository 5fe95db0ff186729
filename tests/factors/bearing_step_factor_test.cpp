#include "factors/bearing_step_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;
using testing::vecBlock;

/// A landmark anchored in a and seen from i and k, with exact bearings.
struct StepScene {
  SE3 T_W_Ba, T_W_Bi, T_W_Bk, T_B_C;
  Vec3 bearing_Ca, bearing_Ci, bearing_Ck;
  double rho;
  std::vector<std::vector<double>> blocks() const {
    return {quatBlock(Quat(T_W_Ba.rotation())),
            vecBlock(T_W_Ba.translation()),
            quatBlock(Quat(T_W_Bi.rotation())),
            vecBlock(T_W_Bi.translation()),
            quatBlock(Quat(T_W_Bk.rotation())),
            vecBlock(T_W_Bk.translation()),
            {rho}};
  }
};

/// near: k a few centimetres and a degree from i (consecutive keyframes), else anywhere.
StepScene randomScene(std::mt19937& rng, double depth_m, bool near = false) {
  StepScene s;
  s.T_B_C = testing::randomPose(rng, 1.0, 0.2);
  s.T_W_Ba = testing::randomPose(rng);
  s.T_W_Bi = testing::randomPose(rng);
  s.T_W_Bk = near ? s.T_W_Bi * testing::randomPose(rng, 0.02, 0.05) : testing::randomPose(rng);
  s.bearing_Ca = testing::randomVec(rng).normalized();
  s.rho = 1.0 / depth_m;
  const Vec3 p_W = s.T_W_Ba * s.T_B_C * (depth_m * s.bearing_Ca);
  s.bearing_Ci = ((s.T_W_Bi * s.T_B_C).inverse() * p_W).normalized();
  s.bearing_Ck = ((s.T_W_Bk * s.T_B_C).inverse() * p_W).normalized();
  return s;
}

const std::vector<bool> kQuatFlags = {true, false, true, false, true, false, false};

TEST(BearingStepFactor, ZeroResidualAtTrueGeometry) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const StepScene s = randomScene(rng, 0.5 + trial);
    const BearingStepFactor f(s.bearing_Ca, s.bearing_Ci, s.bearing_Ck, s.T_B_C, 0.002);
    EXPECT_LT(testing::evaluate(f, s.blocks()).norm(), 1e-8);
  }
}

TEST(BearingStepFactor, ACreepSharedByBothSightingsCancels) {
  // Both sightings off by the same small offset in camera axes (the track's walk up to i): the
  // anchor factor of k sees it, the step from i to k does not. A further offset at k alone shows
  // at its size over sigma, with the sign of the anchor factor's residual.
  std::mt19937 rng(2);
  StepScene s = randomScene(rng, 4.0, true);
  const double sigma = 1e-3;
  const Vec3 walk = 2e-3 * BearingFactor::tangentBasis(s.bearing_Ck).row(0).transpose();
  const Vec3 bi = (s.bearing_Ci + walk).normalized(), bk = (s.bearing_Ck + walk).normalized();
  const BearingStepFactor shared(s.bearing_Ca, bi, bk, s.T_B_C, sigma);
  const BearingFactor anchor(s.bearing_Ca, bk, s.T_B_C, sigma);
  EXPECT_NEAR(testing::evaluate(anchor, {s.blocks()[0], s.blocks()[1], s.blocks()[4], s.blocks()[5],
                                         s.blocks()[6]})
                  .norm(),
              2.0, 0.01);
  EXPECT_LT(testing::evaluate(shared, s.blocks()).norm(), 0.01);

  const Vec3 step = 1e-3 * BearingFactor::tangentBasis(s.bearing_Ck).row(1).transpose();
  const Vec3 bk2 = (s.bearing_Ck + walk + step).normalized();
  const BearingStepFactor stepped(s.bearing_Ca, bi, bk2, s.T_B_C, sigma);
  const BearingFactor only_k(s.bearing_Ca, (s.bearing_Ck + step).normalized(), s.T_B_C, sigma);
  const Eigen::VectorXd r = testing::evaluate(stepped, s.blocks());
  const Eigen::VectorXd r_k = testing::evaluate(
      only_k, {s.blocks()[0], s.blocks()[1], s.blocks()[4], s.blocks()[5], s.blocks()[6]});
  EXPECT_NEAR(r.norm(), 1.0, 0.01);
  EXPECT_GT(r.dot(r_k), 0.98 * r.norm() * r_k.norm());
}

TEST(BearingStepFactor, EachSightingMayHaveItsOwnCameraPoseInTheBody) {
  std::mt19937 rng(12);
  for (int trial = 0; trial < 10; ++trial) {
    StepScene s = randomScene(rng, 2.0 + trial, true);
    const SE3 T_B_Ca = testing::randomPose(rng, 0.01, 0.02) * s.T_B_C;
    const SE3 T_B_Ci = testing::randomPose(rng, 0.01, 0.02) * s.T_B_C;
    const SE3 T_B_Ck = testing::randomPose(rng, 0.01, 0.02) * s.T_B_C;
    const Vec3 p_W = s.T_W_Ba * T_B_Ca * (s.bearing_Ca / s.rho);
    s.bearing_Ci = ((s.T_W_Bi * T_B_Ci).inverse() * p_W).normalized();
    s.bearing_Ck = ((s.T_W_Bk * T_B_Ck).inverse() * p_W).normalized();
    const Mat2 W = Mat2::Identity() / 0.002;
    const BearingStepFactor own(s.bearing_Ca, s.bearing_Ci, s.bearing_Ck, T_B_Ca, T_B_Ci, T_B_Ck,
                                W);
    const BearingStepFactor rig(s.bearing_Ca, s.bearing_Ci, s.bearing_Ck, s.T_B_C, W);
    EXPECT_LT(testing::evaluate(own, s.blocks()).norm(), 1e-7);
    EXPECT_GT(testing::evaluate(rig, s.blocks()).norm(), 0.1);
    testing::expectJacobiansMatch(own, s.blocks(), kQuatFlags, 1e-5);
  }
}

TEST(BearingStepFactor, JacobiansMatchNumericIncludingFarRays) {
  std::mt19937 rng(3);
  for (const double depth : {0.7, 3.0, 50.0, 1e4}) {
    for (int trial = 0; trial < 5; ++trial) {
      SCOPED_TRACE("depth " + std::to_string(depth));
      StepScene s = randomScene(rng, depth);
      s.bearing_Ci = (s.bearing_Ci + testing::randomVec(rng, 0.05)).normalized();
      s.bearing_Ck = (s.bearing_Ck + testing::randomVec(rng, 0.05)).normalized();
      const BearingStepFactor f(s.bearing_Ca, s.bearing_Ci, s.bearing_Ck, s.T_B_C, 0.01);
      testing::expectJacobiansMatch(f, s.blocks(), kQuatFlags, 1e-5);
    }
  }
}

}  // namespace
}  // namespace ovo::factors
