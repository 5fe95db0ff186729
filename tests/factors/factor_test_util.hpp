// Helpers for the factor tests: random geometry and a check of a cost function's analytic
// Jacobians against central differences in the blocks' tangent spaces (Ceres's own Plus).
#pragma once

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include <functional>
#include <random>
#include <vector>

#include "common/so3.hpp"
#include "common/types.hpp"
#include "factors/parameterization.hpp"
#include "tests/test_support.hpp"

namespace ovo::factors::testing {

inline Quat randomQuat(std::mt19937& rng, double max_angle_rad = 3.0) {
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  Vec3 axis = ovo::test::draw3(u, rng);
  axis.normalize();
  return Quat(Eigen::AngleAxisd(max_angle_rad * 0.5 * (u(rng) + 1.0), axis));
}
inline Vec3 randomVec(std::mt19937& rng, double scale = 1.0) {
  std::uniform_real_distribution<double> u(-scale, scale);
  return ovo::test::draw3(u, rng);
}
inline SE3 randomPose(std::mt19937& rng, double max_angle_rad = 3.0, double scale = 2.0) {
  SE3 T = SE3::Identity();
  T.linear() = randomQuat(rng, max_angle_rad).toRotationMatrix();
  T.translation() = randomVec(rng, scale);
  return T;
}
inline std::vector<double> quatBlock(const Quat& q) {
  std::vector<double> b(4);
  quatToBlock(q, b.data());
  return b;
}
inline std::vector<double> vecBlock(const Vec3& v) { return {v.x(), v.y(), v.z()}; }

/// Gyro samples of the rate rate_of_t(t [s]) every `step` from t0 to t1 (200 Hz by default).
inline std::vector<ImuSample> samplesOf(const std::function<Vec3(double)>& rate_of_t, Timestamp t0,
                                        Timestamp t1, Timestamp step = 5'000'000) {
  std::vector<ImuSample> out;
  for (Timestamp t = t0; t <= t1; t += step) out.push_back({t, rate_of_t(toSeconds(t))});
  return out;
}

/// Residual of cost at the given blocks (empty vector when Evaluate fails).
inline Eigen::VectorXd evaluate(const ceres::CostFunction& cost,
                                const std::vector<std::vector<double>>& blocks) {
  std::vector<const double*> ptrs;
  for (const auto& b : blocks) ptrs.push_back(b.data());
  Eigen::VectorXd r(cost.num_residuals());
  if (!cost.Evaluate(ptrs.data(), r.data(), nullptr)) return Eigen::VectorXd();
  return r;
}

/// Analytic Jacobians of `cost` mapped to tangent space (J_ambient * PlusJacobian) for each block.
inline std::vector<Eigen::MatrixXd> tangentJacobians(const ceres::CostFunction& cost,
                                                     const std::vector<std::vector<double>>& blocks,
                                                     const std::vector<bool>& is_quat) {
  const int m = cost.num_residuals();
  std::vector<const double*> ptrs;
  std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J;
  std::vector<double*> jptrs;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    ptrs.push_back(blocks[i].data());
    J.emplace_back(m, static_cast<int>(blocks[i].size()));
  }
  for (auto& j : J) jptrs.push_back(j.data());
  Eigen::VectorXd r(m);
  EXPECT_TRUE(cost.Evaluate(ptrs.data(), r.data(), jptrs.data()));
  std::vector<Eigen::MatrixXd> out;
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    if (is_quat[i]) {
      out.push_back(J[i] * quaternionPlusJacobian(blocks[i].data()));
    } else {
      out.push_back(J[i]);
    }
  }
  return out;
}

/// Numeric tangent Jacobian of block i: d residual(Plus(x_i, d)) / d d at d = 0.
inline Eigen::MatrixXd numericTangentJacobian(const ceres::CostFunction& cost,
                                              const std::vector<std::vector<double>>& blocks,
                                              const std::vector<bool>& is_quat, std::size_t i,
                                              double h = 1e-6) {
  static const ceres::EigenQuaternionManifold quat_manifold;
  const int tangent = is_quat[i] ? 3 : static_cast<int>(blocks[i].size());
  const auto f = [&](const Eigen::VectorXd& d) -> Eigen::VectorXd {
    auto perturbed = blocks;
    if (is_quat[i]) {
      quat_manifold.Plus(blocks[i].data(), d.data(), perturbed[i].data());
    } else {
      for (int k = 0; k < tangent; ++k) perturbed[i][k] += d[k];
    }
    return evaluate(cost, perturbed);
  };
  return ovo::test::numericJacobian(f, Eigen::VectorXd::Zero(tangent), h);
}

/// Expects every block's analytic Jacobian to match the numeric one.
inline void expectJacobiansMatch(const ceres::CostFunction& cost,
                                 const std::vector<std::vector<double>>& blocks,
                                 const std::vector<bool>& is_quat, double tol = 1e-6) {
  const auto analytic = tangentJacobians(cost, blocks, is_quat);
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    SCOPED_TRACE("parameter block " + std::to_string(i));
    OVO_EXPECT_JACOBIAN_NEAR(analytic[i], numericTangentJacobian(cost, blocks, is_quat, i), tol);
  }
}

}  // namespace ovo::factors::testing
