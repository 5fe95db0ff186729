#include "factors/bias_prior_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

using testing::vecBlock;

TEST(BiasPriorFactor, ResidualIsTheBiasOffThePriorInSigmas) {
  const BiasPriorFactor f(Vec3(0.01, -0.02, 0.003), 0.002);
  EXPECT_LT(testing::evaluate(f, {vecBlock(Vec3(0.01, -0.02, 0.003))}).norm(), 1e-12);
  const Eigen::VectorXd r = testing::evaluate(f, {vecBlock(Vec3(0.014, -0.02, -0.001))});
  EXPECT_NEAR(r[0], 2.0, 1e-9);
  EXPECT_NEAR(r[1], 0.0, 1e-9);
  EXPECT_NEAR(r[2], -2.0, 1e-9);
}

TEST(BiasPriorFactor, JacobiansMatchNumeric) {
  std::mt19937 rng(5);
  for (int trial = 0; trial < 5; ++trial) {
    const BiasPriorFactor f(testing::randomVec(rng, 0.05), 1e-3 * (trial + 1));
    testing::expectJacobiansMatch(f, {vecBlock(testing::randomVec(rng, 0.05))}, {false}, 1e-6);
  }
}

}  // namespace
}  // namespace ovo::factors
