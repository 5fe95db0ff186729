#include "factors/pose_prior_factor.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>

#include "common/so3.hpp"

namespace ovo::factors {

PosePriorFactor::PosePriorFactor(const SE3& T_W_B0, const Mat6& information)
    : R_W_B0_(T_W_B0.rotation()), p_W_B0_(T_W_B0.translation()) {
  const Eigen::SelfAdjointEigenSolver<Mat6> eig(0.5 * (information + information.transpose()));
  const Eigen::Matrix<double, 6, 1> sqrt_lambda = eig.eigenvalues().cwiseMax(0.0).cwiseSqrt();
  sqrt_information_ = sqrt_lambda.asDiagonal() * eig.eigenvectors().transpose();
}

Mat6 PosePriorFactor::gaugeInformation(double sigma_position_m, double sigma_yaw_rad,
                                       double sigma_roll_pitch_rad) {
  const auto inv2 = [](double s) { return std::isinf(s) ? 0.0 : 1.0 / (s * s); };
  Eigen::Matrix<double, 6, 1> d;
  d << inv2(sigma_roll_pitch_rad), inv2(sigma_roll_pitch_rad), inv2(sigma_yaw_rad),
      Vec3::Constant(inv2(sigma_position_m));
  return d.asDiagonal();
}

bool PosePriorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Mat3 R_W_B = quatFromBlock(parameters[0]).toRotationMatrix();
  const Eigen::Map<const Vec3> p_W_B(parameters[1]);
  const Vec3 theta = so3::log(R_W_B * R_W_B0_.transpose());
  Eigen::Matrix<double, 6, 1> e;
  e << theta, p_W_B - p_W_B0_;
  Eigen::Map<Eigen::Matrix<double, 6, 1>> residual(residuals);
  residual = sqrt_information_ * e;
  if (!jacobians) return true;
  // Log(Exp(eps) Exp(theta)) ~ theta + Jl^-1(theta) eps, Jl^-1(theta) = Jr^-1(theta)^T.
  if (jacobians[0]) {
    const Eigen::Matrix<double, 6, 3> J_theta =
        sqrt_information_.leftCols<3>() * so3::rightJacobianInverse(theta).transpose();
    rotationJacobianToAmbient<6>(J_theta, parameters[0], jacobians[0]);
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 6, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = sqrt_information_.rightCols<3>();
  }
  return true;
}

}  // namespace ovo::factors
