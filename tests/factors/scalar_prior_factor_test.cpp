#include "factors/scalar_prior_factor.hpp"

#include <gtest/gtest.h>

#include "tests/factors/factor_test_util.hpp"

namespace ovo::factors {
namespace {

TEST(ScalarPriorFactor, IsTheWhitenedDistanceFromItsMean) {
  const ScalarPriorFactor f(0.01, 0.005);
  const auto r = testing::evaluate(f, {{0.02}});
  ASSERT_EQ(r.size(), 1);
  EXPECT_NEAR(r[0], 2.0, 1e-12);
  EXPECT_NEAR(testing::evaluate(f, {{0.0}})[0], -2.0, 1e-12);
  testing::expectJacobiansMatch(f, {{0.004}}, {false});
}

}  // namespace
}  // namespace ovo::factors
