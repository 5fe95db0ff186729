#include "factors/ground_height_factor.hpp"

#include <gtest/gtest.h>

#include <cmath>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

// Camera 1 m above flat ground, looking forward and 30 deg down (x right, y down, z forward).
struct GroundScene {
  Vec3 up_C;
  Vec3 bearing_C;
  double depth_m;
};

GroundScene groundScene() {
  GroundScene s;
  const double pitch = 30.0 * M_PI / 180.0;
  s.up_C = Vec3(0.0, -std::cos(pitch), -std::sin(pitch));  // world up seen from the camera
  // A ground point 2 m ahead of and 0.5 m right of the camera foot, 1 m below the camera.
  const Vec3 fwd_h(0.0, -std::sin(pitch), std::cos(pitch));  // horizontal forward in C
  const Vec3 right(1.0, 0.0, 0.0);
  const Vec3 p_C = 2.0 * fwd_h + 0.5 * right - 1.0 * s.up_C;
  s.depth_m = p_C.norm();
  s.bearing_C = p_C / s.depth_m;
  return s;
}

TEST(GroundHeightFactor, ZeroOnTheGroundAndPositiveForAPointBelowIt) {
  const GroundScene s = groundScene();
  const GroundHeightFactor f(s.bearing_C, s.up_C, 1.0, 0.02);
  EXPECT_NEAR(testing::evaluate(f, {{1.0 / s.depth_m}})[0], 0.0, 1e-12);
  // Twice as far along the ray: the point is 2 m below the camera, 1 m too deep = 50 sigmas.
  EXPECT_NEAR(testing::evaluate(f, {{0.5 / s.depth_m}})[0], 50.0, 1e-9);
  EXPECT_LT(testing::evaluate(f, {{2.0 / s.depth_m}})[0], 0.0);
}

TEST(GroundHeightFactor, JacobianMatchesNumeric) {
  const GroundScene s = groundScene();
  const GroundHeightFactor f(s.bearing_C, s.up_C, 1.0, 0.02);
  testing::expectJacobiansMatch(f, {{0.8 / s.depth_m}}, {false});
}

// With the height's correction as a state: a camera 1 m up with the rig saying 0.98 m is right
// once the correction is +2 cm; each cm of correction moves the residual by one cm in sigmas.
TEST(GroundHeightCorrectedFactor, TheCorrectionAddsToTheRigsHeight) {
  const GroundScene s = groundScene();
  const GroundHeightCorrectedFactor f(s.bearing_C, s.up_C, 0.98, 0.02);
  EXPECT_NEAR(testing::evaluate(f, {{1.0 / s.depth_m}, {0.02}})[0], 0.0, 1e-12);
  EXPECT_NEAR(testing::evaluate(f, {{1.0 / s.depth_m}, {0.0}})[0], 1.0, 1e-9);
  EXPECT_NEAR(testing::evaluate(f, {{1.0 / s.depth_m}, {0.04}})[0], -1.0, 1e-9);
  testing::expectJacobiansMatch(f, {{0.8 / s.depth_m}, {0.013}}, {false, false});
  EXPECT_EQ(testing::evaluate(GroundHeightCorrectedFactor(-s.bearing_C, s.up_C, 1.0, 0.02),
                              {{0.5}, {0.0}})
                .size(),
            0);
}

// The correction's walk along the path, a Gauss-Markov process in the distance driven (sigma 1
// cm, correlation length 3 m): far apart the two are independent (the later one's residual is its
// own value in sigmas); a short step lets it change by sigma sqrt(2 d / L); standing still ties
// them, so a parked robot's correction cannot wander.
TEST(CameraHeightWalkFactor, WandersWithTheDistanceDrivenNotTheTime) {
  const double sigma = 0.01, length = 3.0;
  const CameraHeightWalkFactor far(1000.0, sigma, length);
  EXPECT_NEAR(testing::evaluate(far, {{0.02}, {0.005}})[0], 0.5, 1e-9);
  // 0.3 m driven: a change of sigma sqrt(2 * 0.3 / 3) = 4.5 mm is about one sigma of the step (the
  // exact process: sigma sqrt(1 - exp(-0.2)) = 4.3 mm, the mean pulled towards 0 by exp(-0.1)).
  const CameraHeightWalkFactor step(0.3, sigma, length);
  const double a = std::exp(-0.1), s = sigma * std::sqrt(1.0 - a * a);
  EXPECT_NEAR(testing::evaluate(step, {{0.0}, {s}})[0], 1.0, 1e-9);
  EXPECT_NEAR(testing::evaluate(step, {{0.01}, {0.01 * a}})[0], 0.0, 1e-12);
  // Parked (0 m, floored at 0.1 mm): 1 mm of change is more than 10 sigmas.
  const CameraHeightWalkFactor parked(0.0, sigma, length);
  EXPECT_GT(std::abs(testing::evaluate(parked, {{0.0}, {0.001}})[0]), 10.0);
  testing::expectJacobiansMatch(step, {{0.004}, {-0.007}}, {false, false});
}

TEST(GroundHeightFactor, RejectsABearingAboveTheHorizon) {
  const GroundScene s = groundScene();
  const GroundHeightFactor f(-s.bearing_C, s.up_C, 1.0, 0.02);
  EXPECT_EQ(testing::evaluate(f, {{0.5}}).size(), 0);
}

}  // namespace
}  // namespace ovo::factors
