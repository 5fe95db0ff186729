// Benchmarks of factors/: gyro preintegration, one bearing-factor evaluation, and a synthetic
// 10-keyframe window solve with DENSE_SCHUR vs SPARSE_SCHUR (to choose the estimator's solver).
#include <benchmark/benchmark.h>
#include <ceres/ceres.h>

#include <algorithm>
#include <array>
#include <memory>
#include <random>
#include <vector>

#include "common/so3.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/gyro_preintegration.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/parameterization.hpp"
#include "factors/pose_prior_factor.hpp"
#include "tests/estimator/window/synthetic_bundle.hpp"

namespace {

using namespace ovo;
using namespace ovo::factors;

std::vector<ImuSample> gyroSamples(int count, Timestamp step_ns) {
  std::vector<ImuSample> out(count);
  for (int k = 0; k < count; ++k) {
    const double t = k * toSeconds(step_ns);
    out[k].t_ns = k * step_ns;
    out[k].gyro_radps = Vec3(0.1 * std::sin(t), -0.05, 0.3 * std::cos(2 * t));
  }
  return out;
}

void BM_GyroPreintegration(benchmark::State& state) {
  const auto samples = gyroSamples(202, 5'000'000);
  for (auto _ : state) {
    GyroPreintegration pre(samples, 2'500'000, 1'002'500'000, Vec3(0.01, 0.0, -0.01));
    benchmark::DoNotOptimize(pre.deltaR().data());
  }
  state.SetItemsProcessed(state.iterations() * 200);
}
BENCHMARK(BM_GyroPreintegration)->Name("BM_GyroPreintegration/200samples");

void BM_BearingFactorEval(benchmark::State& state) {
  SE3 T_B_C = SE3::Identity();
  T_B_C.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // camera looks along body x
  const BearingFactor f(Vec3(0.1, 0.2, 1).normalized(), Vec3(0.12, 0.19, 1).normalized(), T_B_C,
                        0.003);
  double q_a[4] = {0, 0, 0, 1}, p_a[3] = {0, 0, 0}, q_j[4] = {0, 0, 0.0499792, 0.9987503},
         p_j[3] = {0.3, 0.02, 0}, rho[1] = {0.2};
  const double* params[5] = {q_a, p_a, q_j, p_j, rho};
  double residuals[2], J0[8], J1[6], J2[8], J3[6], J4[2];
  double* jacobians[5] = {J0, J1, J2, J3, J4};
  for (auto _ : state) {
    f.Evaluate(params, residuals, jacobians);
    benchmark::DoNotOptimize(residuals);
    benchmark::DoNotOptimize(J4);
  }
}
BENCHMARK(BM_BearingFactorEval)->Name("BM_BearingFactor/eval");

// tests/estimator/window/synthetic_bundle.hpp's bundle: 10 keyframes, 100 landmarks, no
// mismatches; 10 Levenberg-Marquardt iterations at most.
void BM_SyntheticWindowSolve(benchmark::State& state, ceres::LinearSolverType solver) {
  ovo::test::SyntheticBundle window(100, 0.0, 7);
  ceres::HuberLoss huber(1.0);
  ceres::EigenQuaternionManifold quat_manifold;
  ceres::Solver::Summary summary;
  for (auto _ : state) {
    state.PauseTiming();
    window.reset();
    ceres::Problem::Options po;
    po.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    po.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
    ceres::Problem problem(po);
    for (const auto& r : window.residuals)
      problem.AddResidualBlock(r.cost.get(), r.robust ? &huber : nullptr, r.blocks);
    for (auto& qk : window.q) problem.SetManifold(qk.data(), &quat_manifold);
    for (double& rho : window.rho) problem.SetParameterLowerBound(&rho, 0, 1e-4);
    ceres::Solver::Options options;
    options.linear_solver_type = solver;
    options.max_num_iterations = 10;
    options.num_threads = 1;
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    for (double& rho : window.rho) ordering->AddElementToGroup(&rho, 0);
    for (int k = 0; k < ovo::test::SyntheticBundle::kKeyframes; ++k) {
      ordering->AddElementToGroup(window.q[k].data(), 1);
      ordering->AddElementToGroup(window.p[k].data(), 1);
      ordering->AddElementToGroup(window.b[k].data(), 1);
    }
    options.linear_solver_ordering = ordering;
    state.ResumeTiming();
    ceres::Solve(options, &problem, &summary);
  }
  state.counters["iterations"] = static_cast<double>(summary.iterations.size());
  state.counters["final_cost"] = summary.final_cost;
  state.counters["initial_cost"] = summary.initial_cost;
}
BENCHMARK_CAPTURE(BM_SyntheticWindowSolve, dense_schur, ceres::DENSE_SCHUR)
    ->Name("BM_SyntheticWindowSolve/10kf/dense_schur")
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_SyntheticWindowSolve, sparse_schur, ceres::SPARSE_SCHUR)
    ->Name("BM_SyntheticWindowSolve/10kf/sparse_schur")
    ->Unit(benchmark::kMillisecond);

}  // namespace
