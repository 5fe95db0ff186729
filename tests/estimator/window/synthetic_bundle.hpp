// A bundle with the window's factor types for the solver's tests and benchmarks: ten keyframes
// 0.3 m apart along a gently turning path, landmarks 3..20 m away anchored in the first five and
// seen from every later keyframe (bearings under a Huber loss, a fraction of them mismatched 2 deg
// off), LiDAR ranges on every fifth landmark, gyro and bias random-walk factors between
// consecutive keyframes and a pose prior on the first. The start is perturbed. Deterministic for
// a seed.
#pragma once

#include <ceres/cost_function.h>
#include <ceres/loss_function.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "common/so3.hpp"
#include "factors/bearing_factor.hpp"
#include "factors/gyro_preintegration.hpp"
#include "factors/lidar_range_factor.hpp"
#include "factors/parameterization.hpp"
#include "factors/pose_prior_factor.hpp"
#include "tests/test_support.hpp"

namespace ovo::test {

struct SyntheticBundle {
  static constexpr int kKeyframes = 10;
  std::vector<std::array<double, 4>> q;
  std::vector<std::array<double, 3>> p, b;
  std::vector<double> rho;
  std::vector<std::array<double, 4>> q_init;
  std::vector<std::array<double, 3>> p_init, b_init;
  std::vector<double> rho_init;
  struct Residual {
    std::shared_ptr<ceres::CostFunction> cost;
    bool robust;
    std::vector<double*> blocks;
  };
  std::vector<Residual> residuals;
  ceres::HuberLoss huber{1.0};

  SyntheticBundle(const SyntheticBundle&) = delete;  // the residuals point into its arrays
  SyntheticBundle& operator=(const SyntheticBundle&) = delete;

  SyntheticBundle(int landmarks, double outlier_fraction, std::uint32_t seed) {
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
      factors::quatToBlock(Quat(so3::exp(0.01 * ovo::test::draw3(n, rng)) * T.rotation()),
                           q[k].data());
      for (int i = 0; i < 3; ++i) p[k][i] = T.translation()[i] + 0.05 * n(rng);
    }
    rho.reserve(landmarks);  // blocks point into it
    const double sigma = 1.0 / 305.0;
    for (int l = 0; l < landmarks; ++l) {
      const int anchor = l % 5;
      const Vec2 r = draw2(u, rng);
      const Vec3 dir_C = Vec3(r.x(), 0.5 * r.y(), 1.0).normalized();
      const double depth = 3.0 + 17.0 * 0.5 * (u(rng) + 1.0);
      const Vec3 p_W = T_W_B[anchor] * T_B_C * (depth * dir_C);
      rho.push_back(1.0 / depth * (1.0 + 0.1 * n(rng)));
      for (int j = anchor + 1; j < kKeyframes; ++j) {
        Vec3 b_Cj = ((T_W_B[j] * T_B_C).inverse() * p_W).normalized();
        if (outlier_fraction > 0.0 && 0.5 * (u(rng) + 1.0) < outlier_fraction)  // 2 deg off
          b_Cj = (so3::exp(Vec3(0.035, -0.02, 0.01)) * b_Cj).normalized();
        const Vec3 noisy = (b_Cj + sigma * ovo::test::draw3(n, rng)).normalized();
        residuals.push_back(
            {std::make_shared<factors::BearingFactor>(dir_C, noisy, T_B_C, sigma),
             true,
             {q[anchor].data(), p[anchor].data(), q[j].data(), p[j].data(), &rho[l]}});
      }
      if (l % 5 == 0) {
        const double range = ((T_W_B[anchor] * T_B_L).inverse() * p_W).norm() + 0.03 * n(rng);
        residuals.push_back(
            {std::make_shared<factors::LidarRangeAnchorFactor>(dir_C, range, T_B_C, T_B_L, 0.03),
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
        s.gyro_radps = w + Vec3(0.01, -0.005, 0.02) + 0.003 * ovo::test::draw3(n, rng);
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
    residuals.push_back({std::make_shared<factors::PosePriorFactor>(
                             T_W_B[0], factors::PosePriorFactor::gaugeInformation(1e-3, 1e-3)),
                         false,
                         {q[0].data(), p[0].data()}});
    q_init = q;
    p_init = p;
    b_init = b;
    rho_init = rho;
  }

  // Restores the perturbed start in place (the residuals point into these arrays).
  void reset() {
    std::copy(q_init.begin(), q_init.end(), q.begin());
    std::copy(p_init.begin(), p_init.end(), p.begin());
    std::copy(b_init.begin(), b_init.end(), b.begin());
    std::copy(rho_init.begin(), rho_init.end(), rho.begin());
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

}  // namespace ovo::test
