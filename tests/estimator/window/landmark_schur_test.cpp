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
#include "tests/test_support.hpp"

namespace ovo::estimator {
namespace {

using factors::BearingFactor;
using factors::LidarRangeAnchorFactor;
using factors::PosePriorFactor;

// Ten keyframes along a gently turning path, landmarks anchored in the first five and seen from
// every later keyframe (bearings with outliers under a Huber loss), LiDAR ranges on some, gyro
// and bias factors between keyframes, a pose prior on the first; the start is perturbed.
struct Bundle {
  static constexpr int kKeyframes = 10;
  std::vector<std::array<double, 4>> q;
  std::vector<std::array<double, 3>> p, b;
  std::vector<double> rho;
  struct Residual {
    std::shared_ptr<ceres::CostFunction> cost;
    bool robust;
    std::vector<double*> blocks;
  };
  std::vector<Residual> residuals;
  ceres::HuberLoss huber{1.0};

  explicit Bundle(int landmarks, double outlier_fraction, std::uint32_t seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0.0, 1.0);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    SE3 T_B_C = SE3::Identity(), T_B_L = SE3::Identity();
    T_B_C.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    T_B_L.translation() = Vec3(0.1, 0, 0.2);
    std::vector<SE3> T_W_B;
    q.resize(kKeyframes);
    p.resize(kKeyframes);
    b.assign(kKeyframes, {0, 0, 0});
    for (int k = 0; k < kKeyframes; ++k) {
      SE3 T = SE3::Identity();
      T.linear() = so3::exp(Vec3(0.01 * std::sin(k), 0.01, 0.05 * k));
      T.translation() = Vec3(0.3 * k, 0.02 * k * k, 0.01 * std::sin(k));
      T_W_B.push_back(T);
      factors::quatToBlock(Quat(so3::exp(0.01 * Vec3(n(rng), n(rng), n(rng))) * T.rotation()),
                           q[k].data());
      for (int i = 0; i < 3; ++i) p[k][i] = T.translation()[i] + 0.05 * n(rng);
    }
    rho.reserve(landmarks);  // blocks point into it
    const double sigma = 1.0 / 305.0;
    for (int l = 0; l < landmarks; ++l) {
      const int anchor = l % 5;
      const Vec3 dir_C = Vec3(u(rng), 0.5 * u(rng), 1.0).normalized();
      const double depth = 3.0 + 17.0 * 0.5 * (u(rng) + 1.0);
      const Vec3 p_W = T_W_B[anchor] * T_B_C * (depth * dir_C);
      rho.push_back(1.0 / depth * (1.0 + 0.1 * n(rng)));
      for (int j = anchor + 1; j < kKeyframes; ++j) {
        Vec3 b_Cj = ((T_W_B[j] * T_B_C).inverse() * p_W).normalized();
        if (0.5 * (u(rng) + 1.0) < outlier_fraction)  // a mismatch: 2 degrees off
          b_Cj = (so3::exp(Vec3(0.035, -0.02, 0.01)) * b_Cj).normalized();
        const Vec3 noisy = (b_Cj + sigma * Vec3(n(rng), n(rng), n(rng))).normalized();
        residuals.push_back({std::make_shared<BearingFactor>(dir_C, noisy, T_B_C, sigma),
                             true,
                             {q[anchor].data(), p[anchor].data(), q[j].data(), p[j].data(),
                              &rho[l]}});
      }
      if (l % 5 == 0) {
        const double range = ((T_W_B[anchor] * T_B_L).inverse() * p_W).norm() + 0.03 * n(rng);
        residuals.push_back(
            {std::make_shared<LidarRangeAnchorFactor>(dir_C, range, T_B_C, T_B_L, 0.03),
             true,
             {&rho[l]}});
      }
    }
    std::vector<ImuSample> samples;
    constexpr Timestamp kStep = 500'000'000;
    for (int k = 0; k + 1 < kKeyframes; ++k) {
      const Vec3 w = so3::log(T_W_B[k].rotation().transpose() * T_W_B[k + 1].rotation()) / 0.5;
      for (Timestamp t = k * kStep; t < (k + 1) * kStep; t += 5'000'000) {
        ImuSample s;
        s.t_ns = t;
        s.gyro_radps = w + Vec3(0.01, -0.005, 0.02) + 0.003 * Vec3(n(rng), n(rng), n(rng));
        samples.push_back(s);
      }
    }
    samples.push_back(samples.back());
    samples.back().t_ns += 5'000'000;
    for (int k = 0; k + 1 < kKeyframes; ++k) {
      auto pre = std::make_shared<factors::GyroPreintegration>(samples, k * kStep, (k + 1) * kStep,
                                                               Vec3::Zero());
      residuals.push_back({std::make_shared<factors::GyroFactor>(pre),
                           false,
                           {q[k].data(), q[k + 1].data(), b[k].data()}});
      residuals.push_back({std::make_shared<factors::BiasRandomWalkFactor>(1e-4, 0.5),
                           false,
                           {b[k].data(), b[k + 1].data()}});
    }
    residuals.push_back(
        {std::make_shared<PosePriorFactor>(T_W_B[0], PosePriorFactor::gaugeInformation(1e-3, 1e-3)),
         false,
         {q[0].data(), p[0].data()}});
  }

  std::vector<double> state() const {
    std::vector<double> x;
    for (int k = 0; k < kKeyframes; ++k) {
      x.insert(x.end(), q[k].begin(), q[k].end());
      x.insert(x.end(), p[k].begin(), p[k].end());
      x.insert(x.end(), b[k].begin(), b[k].end());
    }
    x.insert(x.end(), rho.begin(), rho.end());
    return x;
  }
};

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

void expectTheSameAsCeres(int landmarks, double outliers, std::uint32_t seed, const SolveSetup& setup) {
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
    test::feedSequence(seq, core, [&](std::size_t, const FrameEstimate& e) {
      poses.push_back(e.T_W_B);
    });
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
    worst_rad = std::max(worst_rad, so3::log(own[i].rotation().transpose() *
                                             ceres_poses[i].rotation())
                                        .norm());
  }
  EXPECT_LT(worst_m, 1e-6);
  EXPECT_LT(worst_rad, 1e-6);
}

}  // namespace
}  // namespace ovo::estimator
