// The window's own minimiser against Ceres (its solver of record): on a bundle problem with the
// window's factor types, and on whole window runs, it takes the same steps as Ceres' LM with
// DENSE_SCHUR and ends at the same states (to 1e-6; the runs measured agree to about 1e-11).
#include "estimator/window/landmark_schur.hpp"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "common/so3.hpp"
#include "estimator/window/core.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/gyro_preintegration.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/parameterization.hpp"
#include "factors/pose_prior_factor.hpp"
#include "tests/estimator/window/synthetic.hpp"
#include "tests/estimator/window/synthetic_bundle.hpp"
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

using factors::BearingFactor;
using factors::LidarRangeAnchorFactor;
using factors::PosePriorFactor;

using Bundle = test::SyntheticBundle;

struct SolveSetup {
  int iterations = 10;
  double max_rho = 10.0;
  bool hold_first_bias = false;
};

// Ceres' LM with DENSE_SCHUR, as the window ran it before its own minimiser.
ceres::Solver::Summary solveWithCeres(Bundle& bundle, const SolveSetup& setup) {
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  for (const auto& r : bundle.residuals)
    problem.AddResidualBlock(r.cost.get(), r.robust ? &bundle.huber : nullptr, r.blocks);
  for (auto& qk : bundle.q) problem.SetManifold(qk.data(), new ceres::EigenQuaternionManifold);
  for (double& rho : bundle.rho) {
    problem.SetParameterLowerBound(&rho, 0, 1e-4);
    problem.SetParameterUpperBound(&rho, 0, setup.max_rho);
  }
  if (setup.hold_first_bias) problem.SetParameterBlockConstant(bundle.b[0].data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.max_num_iterations = setup.iterations;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  return summary;
}

LmSummary solveOwn(Bundle& bundle, const SolveSetup& setup, double stop_decrease = 0.0) {
  std::vector<LmResidual> residuals;
  for (const auto& r : bundle.residuals)
    residuals.push_back({r.cost.get(), r.robust ? &bundle.huber : nullptr, &r.blocks});
  std::unordered_map<const double*, LmBlockInfo> info;
  for (auto& qk : bundle.q) info[qk.data()].quaternion = true;
  for (double& rho : bundle.rho) info[&rho] = {false, false, true, 1e-4, setup.max_rho};
  if (setup.hold_first_bias) info[bundle.b[0].data()].constant = true;
  LmOptions options;
  options.max_iterations = setup.iterations;
  options.stop_decrease = stop_decrease;
  return solveLandmarkSchur(residuals, info, options);
}

double maxDifference(const std::vector<double>& a, const std::vector<double>& b) {
  double d = 0.0;
  for (std::size_t i = 0; i < a.size(); ++i) d = std::max(d, std::abs(a[i] - b[i]));
  return d;
}

void expectTheSameAsCeres(int landmarks, double outliers, std::uint32_t seed,
                          const SolveSetup& setup) {
  Bundle with_ceres(landmarks, outliers, seed), own(landmarks, outliers, seed);
  ASSERT_EQ(with_ceres.state(), own.state());
  const auto c = solveWithCeres(with_ceres, setup);
  const LmSummary o = solveOwn(own, setup);
  ASSERT_FALSE(o.failed) << o.message;
  EXPECT_LT(c.final_cost, 0.5 * c.initial_cost);  // the problem is one to solve
  EXPECT_NEAR(o.initial_cost, c.initial_cost, 1e-9 * c.initial_cost);
  EXPECT_NEAR(o.final_cost, c.final_cost, 1e-6 * c.final_cost);
  EXPECT_EQ(o.iterations, static_cast<int>(c.iterations.size()));
  EXPECT_EQ(o.accepted + 1, c.num_successful_steps);  // Ceres counts the start as one
  EXPECT_LT(maxDifference(own.state(), with_ceres.state()), 1e-6);
}

TEST(LandmarkSchur, TakesCeresStepsOnABundleWithTheWindowsFactors) {
  expectTheSameAsCeres(100, 0.0, 7, {});
}

TEST(LandmarkSchur, TakesCeresStepsWithOutliersAConstantBlockAndFewIterations) {
  expectTheSameAsCeres(150, 0.05, 11, {4, 10.0, true});
}

TEST(LandmarkSchur, RejectsAndShrinksAsCeresDoesFromAFarStart) {
  // Inverse depths bounded tight below the truth: steps run into the bounds and LM's radius
  // shrinks on rejected steps; the answers still match.
  SolveSetup setup;
  setup.max_rho = 0.08;
  setup.iterations = 20;
  Bundle with_ceres(80, 0.1, 5), own(80, 0.1, 5);
  const auto c = solveWithCeres(with_ceres, setup);
  const LmSummary o = solveOwn(own, setup);
  EXPECT_GT(c.num_unsuccessful_steps, 0);
  EXPECT_EQ(o.iterations, static_cast<int>(c.iterations.size()));
  EXPECT_LT(maxDifference(own.state(), with_ceres.state()), 1e-6);
  for (double rho : own.rho) EXPECT_LE(rho, 0.08);
}

TEST(LandmarkSchur, StopsOnceAStepGainsLittle) {
  // Without the rule it takes every step it is given; with it, it stops after the first step
  // that lowers the cost by less than the fraction, close to where the full solve ends.
  SolveSetup setup;
  setup.iterations = 20;
  Bundle full(100, 0.05, 3), stopped(100, 0.05, 3);
  const LmSummary f = solveOwn(full, setup);
  const LmSummary s = solveOwn(stopped, setup, 1e-3);
  ASSERT_FALSE(s.failed) << s.message;
  EXPECT_LT(s.iterations, f.iterations);
  EXPECT_EQ(s.message, "cost decrease below stop_decrease");
  EXPECT_LT(s.final_cost, 0.5 * s.initial_cost);
  EXPECT_LT(s.final_cost - f.final_cost, 1e-2 * f.final_cost);
}

// A factor that cannot be evaluated at the start: the solve fails and leaves the states.
struct Unevaluable final : ceres::SizedCostFunction<1, 3> {
  bool Evaluate(double const* const*, double*, double**) const override { return false; }
};

TEST(LandmarkSchur, AStartThatCannotBeEvaluatedFailsAndLeavesTheStates) {
  std::array<double, 3> x = {1.0, 2.0, 3.0};
  Unevaluable cost;
  const std::vector<double*> blocks = {x.data()};
  const LmSummary s = solveLandmarkSchur({{&cost, nullptr, &blocks}}, {}, {});
  EXPECT_TRUE(s.failed);
  EXPECT_EQ(x, (std::array<double, 3>{1.0, 2.0, 3.0}));
}

// The whole window (gyro, bias, LiDAR, ground and marginalisation factors, outlier passes,
// rescales) with its own minimiser and with Ceres: the same trajectory.
TEST(LandmarkSchur, AWindowRunGivesCeresTrajectory) {
  test::SyntheticOptions o;
  o.duration_s = 8.0;
  const auto seq =
      test::makeSyntheticSequence(o, test::sourcePath("configs/cameras/romovi_ocam.txt"));
  const auto run = [&](LinearSolver solver) {
    WindowOptions options;
    options.linear_solver = solver;
    options.solver_stop_decrease = 0.0;  // Ceres' steps: only the iteration count stops it
    WindowCore core(seq.setup, options);
    std::vector<SE3> poses;
    test::feedSequence(seq, core,
                       [&](std::size_t, const FrameEstimate& e) { poses.push_back(e.T_W_B); });
    return std::make_pair(poses, core.stats());
  };
  const auto [own, own_stats] = run(LinearSolver::kLandmarkSchur);
  const auto [ceres_poses, ceres_stats] = run(LinearSolver::kDenseSchur);
  ASSERT_EQ(own.size(), ceres_poses.size());
  ASSERT_GT(own_stats.keyframes, 10);
  EXPECT_EQ(own_stats.keyframes, ceres_stats.keyframes);
  EXPECT_EQ(own_stats.solve_failures, 0);
  double worst_m = 0.0, worst_rad = 0.0;
  for (std::size_t i = 0; i < own.size(); ++i) {
    worst_m = std::max(worst_m, (own[i].translation() - ceres_poses[i].translation()).norm());
    worst_rad = std::max(
        worst_rad, so3::log(own[i].rotation().transpose() * ceres_poses[i].rotation()).norm());
  }
  EXPECT_LT(worst_m, 1e-6);
  EXPECT_LT(worst_rad, 1e-6);
}

}  // namespace
}  // namespace ovo::estimator
