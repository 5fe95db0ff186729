#include "factors/rotation_tie_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::quatBlock;

TEST(RotationTieFactor, ResidualIsTheVisionsRotationOffTheGyroChainsInSigmas) {
  std::mt19937 rng(3);
  const Quat q_G = testing::randomQuat(rng);
  const RotationTieFactor f(1e-3);
  EXPECT_LT(testing::evaluate(f, {quatBlock(q_G), quatBlock(q_G)}).norm(), 1e-9);
  // The vision's orientation turned by +2 mrad about the body's y axis: r = (0, 2, 0).
  const Quat q_B = q_G * Quat(Eigen::AngleAxisd(2e-3, Vec3::UnitY()));
  const Eigen::VectorXd r = testing::evaluate(f, {quatBlock(q_B), quatBlock(q_G)});
  EXPECT_NEAR(r[0], 0.0, 1e-9);
  EXPECT_NEAR(r[1], 2.0, 1e-6);
  EXPECT_NEAR(r[2], 0.0, 1e-9);
}

TEST(RotationTieFactor, JacobiansMatchNumeric) {
  std::mt19937 rng(8);
  const RotationTieFactor f(2e-3);
  for (int trial = 0; trial < 10; ++trial) {
    const Quat q_G = testing::randomQuat(rng);
    const Quat q_B = q_G * testing::randomQuat(rng, 0.5);
    testing::expectJacobiansMatch(f, {quatBlock(q_B), quatBlock(q_G)}, {true, true}, 1e-5);
  }
}

}  // namespace
}  // namespace ovo::factors
