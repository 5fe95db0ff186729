// solveFactors on a problem Ceres cannot start (a factor that fails to evaluate at the start
// point): the summary says it failed and every state is as it was before the solve.
#include "estimator/window/solve.hpp"

#include <ceres/sized_cost_function.h>
#include <gtest/gtest.h>

#include <memory>

namespace ovo::estimator {
namespace {

// A one-residual factor on a keyframe's position that cannot be evaluated.
struct Unevaluable final : ceres::SizedCostFunction<1, 3> {
  bool Evaluate(double const* const*, double*, double**) const override { return false; }
};

TEST(SolveFactors, AFailedSolveSaysSoAndRestoresTheStates) {
  Keyframe kf(SE3::Identity());
  SE3 T = SE3::Identity();
  T.translation() = Vec3(1.0, 2.0, 3.0);
  kf.setPose(T);
  std::vector<FactorSpec> factors(1);
  factors[0].cost = std::make_unique<Unevaluable>();
  factors[0].blocks = {kf.p_W_B};
  std::unordered_map<TrackId, Landmark> landmarks;
  WindowModel model;
  model.use_gyro = false;
  const SolveSummary s = solveFactors(std::move(factors), {&kf}, landmarks, model, {});
  EXPECT_TRUE(s.failed);
  EXPECT_FALSE(s.usable);
  EXPECT_EQ(kf.pose().translation(), Vec3(1.0, 2.0, 3.0));
}

TEST(SolveFactors, NothingToSolveIsNoFailure) {
  std::unordered_map<TrackId, Landmark> landmarks;
  const SolveSummary s = solveFactors({}, {}, landmarks, WindowModel{}, {});
  EXPECT_FALSE(s.failed);
  EXPECT_FALSE(s.usable);
}

}  // namespace
}  // namespace ovo::estimator
