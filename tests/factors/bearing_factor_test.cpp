#include "factors/bearing_factor.hpp"

#include <gtest/gtest.h>

#include "camera/calib_io.hpp"
#include "camera/camera.hpp"
#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;
using testing::vecBlock;

struct BearingScene {
  SE3 T_W_Ba, T_W_Bj, T_B_C;
  Vec3 p_W;  // landmark
  Vec3 bearing_Ca, bearing_Cj;
  double rho;
  std::vector<std::vector<double>> blocks() const {
    return {quatBlock(Quat(T_W_Ba.rotation())),
            vecBlock(T_W_Ba.translation()),
            quatBlock(Quat(T_W_Bj.rotation())),
            vecBlock(T_W_Bj.translation()),
            {rho}};
  }
};

BearingScene randomScene(std::mt19937& rng, double depth_m) {
  BearingScene s;
  s.T_B_C = testing::randomPose(rng, 1.0, 0.2);
  s.T_W_Ba = testing::randomPose(rng);
  s.T_W_Bj = testing::randomPose(rng);
  // Any direction from the anchor camera, including beyond 90 degrees off the optical axis.
  const Vec3 dir_Ca = testing::randomVec(rng).normalized();
  const SE3 T_W_Ca = s.T_W_Ba * s.T_B_C;
  s.p_W = T_W_Ca * (depth_m * dir_Ca);
  s.bearing_Ca = dir_Ca;
  s.rho = 1.0 / depth_m;
  s.bearing_Cj = ((s.T_W_Bj * s.T_B_C).inverse() * s.p_W).normalized();
  return s;
}

const std::vector<bool> kQuatFlags = {true, false, true, false, false};

TEST(BearingFactor, ZeroResidualAtTrueGeometry) {
  std::mt19937 rng(1);
  for (int trial = 0; trial < 20; ++trial) {
    const BearingScene s = randomScene(rng, 0.5 + trial);
    const BearingFactor f(s.bearing_Ca, s.bearing_Cj, s.T_B_C, 0.002);
    EXPECT_LT(testing::evaluate(f, s.blocks()).norm(), 1e-8);
  }
}

TEST(BearingFactor, ResidualIsAngularOffsetOverSigma) {
  // Rotating the measured bearing by a small angle alpha about a tangent axis gives a residual of
  // norm alpha / sigma (to first order).
  std::mt19937 rng(2);
  const BearingScene s = randomScene(rng, 4.0);
  const double alpha = 1e-4, sigma = 1e-3;
  const Vec3 axis = BearingFactor::tangentBasis(s.bearing_Cj).row(0).transpose();
  const Vec3 measured = so3::exp(alpha * axis) * s.bearing_Cj;
  const BearingFactor f(s.bearing_Ca, measured, s.T_B_C, sigma);
  EXPECT_NEAR(testing::evaluate(f, s.blocks()).norm(), alpha / sigma, 1e-6);
}

TEST(BearingFactor, TangentBasisIsOrthonormalAndOrthogonalToBearing) {
  for (const Vec3& b : {Vec3(0, 0, 1), Vec3(0, 0, -1), Vec3(1, 0, 0), Vec3(0.3, -0.8, 0.1)}) {
    const Vec3 bn = b.normalized();
    const auto T = BearingFactor::tangentBasis(bn);
    EXPECT_NEAR((T * T.transpose() - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-12);
    EXPECT_NEAR((T * bn).norm(), 0.0, 1e-12);
  }
}

TEST(BearingFactor, JacobiansMatchNumericIncludingFarAndWideRays) {
  std::mt19937 rng(3);
  for (const double depth : {0.7, 3.0, 50.0, 1e4}) {
    for (int trial = 0; trial < 5; ++trial) {
      SCOPED_TRACE("depth " + std::to_string(depth));
      BearingScene s = randomScene(rng, depth);
      // Off the solution: perturb the measurement so the residual is not zero.
      s.bearing_Cj = (s.bearing_Cj + testing::randomVec(rng, 0.05)).normalized();
      const BearingFactor f(s.bearing_Ca, s.bearing_Cj, s.T_B_C, 0.01);
      testing::expectJacobiansMatch(f, s.blocks(), kQuatFlags, 1e-5);
    }
  }
}

// A rolling shutter: each sighting's camera has its own pose in the body (its row's time). The
// landmark seen through those poses gives a zero residual, and through the rig's one does not.
TEST(BearingFactor, EachSightingMayHaveItsOwnCameraPoseInTheBody) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 10; ++trial) {
    BearingScene s = randomScene(rng, 2.0 + trial);
    const SE3 T_B_Ca = testing::randomPose(rng, 0.01, 0.02) * s.T_B_C;
    const SE3 T_B_Cj = testing::randomPose(rng, 0.01, 0.02) * s.T_B_C;
    const Vec3 p_W = s.T_W_Ba * T_B_Ca * (s.bearing_Ca / s.rho);
    s.bearing_Cj = ((s.T_W_Bj * T_B_Cj).inverse() * p_W).normalized();
    const Mat2 W = Mat2::Identity() / 0.002;
    const BearingFactor own(s.bearing_Ca, s.bearing_Cj, T_B_Ca, T_B_Cj, W);
    const BearingFactor rig(s.bearing_Ca, s.bearing_Cj, s.T_B_C, W);
    EXPECT_LT(testing::evaluate(own, s.blocks()).norm(), 1e-8);
    EXPECT_GT(testing::evaluate(rig, s.blocks()).norm(), 0.1);
    s.bearing_Cj = (s.bearing_Cj + testing::randomVec(rng, 0.05)).normalized();
    const BearingFactor off(s.bearing_Ca, s.bearing_Cj, T_B_Ca, T_B_Cj, W);
    testing::expectJacobiansMatch(off, s.blocks(), kQuatFlags, 1e-5);
  }
}

TEST(BearingFactor, PointAtInfinityIsFiniteAndRotationOnly) {
  std::mt19937 rng(4);
  BearingScene s = randomScene(rng, 5.0);
  s.rho = 0.0;
  const Mat3 R_Cj_Ca = ((s.T_W_Bj * s.T_B_C).inverse() * (s.T_W_Ba * s.T_B_C)).rotation();
  const BearingFactor f(s.bearing_Ca, R_Cj_Ca * s.bearing_Ca, s.T_B_C, 0.001);
  const Eigen::VectorXd r = testing::evaluate(f, s.blocks());
  ASSERT_EQ(r.size(), 2);
  EXPECT_LT(r.norm(), 1e-8);
  testing::expectJacobiansMatch(f, s.blocks(), kQuatFlags, 1e-5);
  const auto b = s.blocks();
  const auto predicted =
      predictBearing(s.bearing_Ca, s.T_B_C.rotation(), s.T_B_C.translation(), b[0].data(),
                     b[1].data(), b[2].data(), b[3].data(), 0.0, true);
  ASSERT_TRUE(predicted.has_value());
  EXPECT_GT(predicted->u.dot(R_Cj_Ca * s.bearing_Ca), 1.0 - 1e-12);
}

// Whitened by the camera's own Jacobian at the sighting (pixels per radian in the bearing's
// tangent axes over the pixel sigma), the residual is the image error in sigmas, wherever in the
// fisheye the sighting is: near the image circle a radian is fewer pixels than at the centre, and
// the same angle is a smaller error there.
TEST(BearingFactor, WhitenedByTheCamerasJacobianTheResidualIsThePixelErrorInSigmas) {
  const auto path = ovo::test::sourcePath("configs/cameras/romovi_ocam.txt");
  const camera::Camera cam = camera::loadCamera(path);
  const double sigma_px = 0.5;
  for (const Vec2& px_true : {Vec2(320.0, 240.0), Vec2(560.0, 250.0), Vec2(330.0, 40.0)}) {
    const Vec3 p_C = 4.0 * *camera::unproject(cam, px_true);
    const Vec2 px_meas = px_true + Vec2(0.6, -0.4);  // 0.72 px off
    const Vec3 b_j = *camera::unproject(cam, px_meas);
    Eigen::Matrix<double, 2, 3> J;
    ASSERT_TRUE(camera::project(cam, b_j, &J));
    const Mat2 px_per_rad = J * BearingFactor::tangentBasis(b_j).transpose();
    // Anchor = observer (identity poses), so the prediction is the true point's bearing.
    const BearingFactor f(p_C.normalized(), b_j, SE3::Identity(), Mat2(px_per_rad / sigma_px));
    const std::vector<std::vector<double>> blocks = {quatBlock(Quat::Identity()),
                                                     vecBlock(Vec3::Zero()),
                                                     quatBlock(Quat::Identity()),
                                                     vecBlock(Vec3::Zero()),
                                                     {1.0 / 4.0}};
    const Vec3 u = p_C.normalized();
    const auto px_u = camera::project(cam, u);
    ASSERT_TRUE(px_u);
    const double err_px = (*px_u - px_meas).norm();
    EXPECT_NEAR(testing::evaluate(f, blocks).norm() * sigma_px, err_px, 0.03 * err_px)
        << "at " << px_true.transpose();
    testing::expectJacobiansMatch(f, blocks, kQuatFlags, 1e-5);
  }
}

}  // namespace
}  // namespace ovo::factors
