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

// A window of 10 keyframes 0.3 m apart along a gently turning path, 100 landmarks 3..20 m away,
// each anchored in one of the first keyframes and seen by the later ones; gyro factors and bias
// random walk between consecutive keyframes, a gauge prior on keyframe 0, LiDAR ranges on 20
// landmarks for scale. Initial values are perturbed; 10 Levenberg-Marquardt iterations at most.
struct SyntheticWindow {
  static constexpr int kKeyframes = 10;
  static constexpr int kLandmarks = 100;
  SE3 T_B_C = SE3::Identity(), T_B_L = SE3::Identity();
  std::vector<SE3> T_W_B;
  std::vector<std::array<double, 4>> q, q_init;
  std::vector<std::array<double, 3>> p, p_init, b, b_init;
  std::vector<double> rho, rho_init;
  struct Residual {
    std::shared_ptr<ceres::CostFunction> cost;
    bool robust;
    std::vector<double*> blocks;
  };
  std::vector<Residual> residuals;

  SyntheticWindow() {
    std::mt19937 rng(7);
    std::normal_distribution<double> n(0.0, 1.0);
    std::uniform_real_distribution<double> u(-1.0, 1.0);
    T_B_C.linear() << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    T_B_L.translation() = Vec3(0.1, 0, 0.2);
    q.resize(kKeyframes);
    p.resize(kKeyframes);
    b.resize(kKeyframes);
    const Vec3 bias(0.01, -0.005, 0.02);
    for (int k = 0; k < kKeyframes; ++k) {
      SE3 T = SE3::Identity();
      T.linear() = so3::exp(Vec3(0.01 * std::sin(k), 0.01, 0.05 * k));
      T.translation() = Vec3(0.3 * k, 0.02 * k * k, 0.01 * std::sin(k));
      T_W_B.push_back(T);
      const Quat qk(so3::exp(0.01 * Vec3(n(rng), n(rng), n(rng))) * T.rotation());
      quatToBlock(qk, q[k].data());
      for (int i = 0; i < 3; ++i) p[k][i] = T.translation()[i] + 0.05 * n(rng);
      b[k] = {0, 0, 0};
    }
    rho.reserve(kLandmarks);                   // blocks point into it
    const double sigma_bearing = 1.0 / 305.0;  // 1 px at the RoMoVi fisheye's 305 px/rad
    for (int l = 0; l < kLandmarks; ++l) {
      const int anchor = l % 5;
      const SE3 T_W_Ca = T_W_B[anchor] * T_B_C;
      const Vec3 dir_C = Vec3(u(rng), 0.5 * u(rng), 1.0).normalized();
      const double depth = 3.0 + 17.0 * 0.5 * (u(rng) + 1.0);
      const Vec3 p_W = T_W_Ca * (depth * dir_C);
      rho.push_back(1.0 / depth * (1.0 + 0.1 * n(rng)));
      for (int j = anchor + 1; j < kKeyframes; ++j) {
        const Vec3 b_Cj = ((T_W_B[j] * T_B_C).inverse() * p_W).normalized();
        const Vec3 noisy = (b_Cj + sigma_bearing * Vec3(n(rng), n(rng), n(rng))).normalized();
        residuals.push_back(
            {std::make_shared<BearingFactor>(dir_C, noisy, T_B_C, sigma_bearing),
             true,
             {q[anchor].data(), p[anchor].data(), q[j].data(), p[j].data(), &rho[l]}});
      }
      if (l % 5 == 0) {
        const double range = ((T_W_B[anchor] * T_B_L).inverse() * p_W).norm() + 0.03 * n(rng);
        residuals.push_back(
            {std::make_shared<LidarRangeAnchorFactor>(dir_C, range, T_B_C, T_B_L, 0.03),
             true,
             {&rho[l]}});
      }
    }
    constexpr Timestamp kKeyframeStepNs = 500'000'000;
    const auto samples = [&] {
      std::vector<ImuSample> out;
      for (int k = 0; k + 1 < kKeyframes; ++k) {
        const Vec3 w = so3::log(T_W_B[k].rotation().transpose() * T_W_B[k + 1].rotation()) / 0.5;
        for (Timestamp t = k * kKeyframeStepNs; t < (k + 1) * kKeyframeStepNs; t += 5'000'000) {
          ImuSample s;
          s.t_ns = t;
          s.gyro_radps = w + bias + 0.003 * Vec3(n(rng), n(rng), n(rng));
          out.push_back(s);
        }
      }
      ImuSample last = out.back();
      last.t_ns += 5'000'000;
      out.push_back(last);
      return out;
    }();
    for (int k = 0; k + 1 < kKeyframes; ++k) {
      auto pre = std::make_shared<GyroPreintegration>(samples, k * kKeyframeStepNs,
                                                      (k + 1) * kKeyframeStepNs, Vec3::Zero());
      residuals.push_back(
          {std::make_shared<GyroFactor>(pre), false, {q[k].data(), q[k + 1].data(), b[k].data()}});
      residuals.push_back({std::make_shared<BiasRandomWalkFactor>(1e-4, 0.5),
                           false,
                           {b[k].data(), b[k + 1].data()}});
    }
    residuals.push_back(
        {std::make_shared<PosePriorFactor>(T_W_B[0], PosePriorFactor::gaugeInformation(1e-3, 1e-3)),
         false,
         {q[0].data(), p[0].data()}});
    q_init = q;
    p_init = p;
    b_init = b;
    rho_init = rho;
  }

  // Restores the initial guess in place (the residuals point into these arrays).
  void reset() {
    std::copy(q_init.begin(), q_init.end(), q.begin());
    std::copy(p_init.begin(), p_init.end(), p.begin());
    std::copy(b_init.begin(), b_init.end(), b.begin());
    std::copy(rho_init.begin(), rho_init.end(), rho.begin());
  }
};

void BM_SyntheticWindowSolve(benchmark::State& state, ceres::LinearSolverType solver) {
  SyntheticWindow window;
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
    for (int k = 0; k < SyntheticWindow::kKeyframes; ++k) {
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
