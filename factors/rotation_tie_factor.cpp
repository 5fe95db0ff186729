#include "factors/rotation_tie_factor.hpp"

#include <algorithm>

#include "common/so3.hpp"

namespace ovo::factors {

RotationTieFactor::RotationTieFactor(double sigma_rad)
    : inv_sigma_(1.0 / std::max(sigma_rad, 1e-12)) {}

bool RotationTieFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const Mat3 R_W_B = quatFromBlock(parameters[0]).toRotationMatrix();
  const Mat3 R_W_G = quatFromBlock(parameters[1]).toRotationMatrix();
  const Vec3 r = so3::log(R_W_G.transpose() * R_W_B);
  Eigen::Map<Vec3> residual(residuals);
  residual = inv_sigma_ * r;
  if (!jacobians) return true;
  // With R <- Exp(theta) R (world-frame perturbation): R_W_G^T Exp(theta_B) R_W_B =
  // R_W_G^T R_W_B Exp(R_W_B^T theta_B), so dr/dtheta_B = Jr^-1(r) R_W_B^T and, likewise,
  // dr/dtheta_G = -Jr^-1(r) R_W_B^T (as the gyro factor's, with dR = I).
  const Mat3 J = inv_sigma_ * so3::rightJacobianInverse(r) * R_W_B.transpose();
  if (jacobians[0]) rotationJacobianToAmbient<3>(J, parameters[0], jacobians[0]);
  if (jacobians[1]) rotationJacobianToAmbient<3>(Mat3(-J), parameters[1], jacobians[1]);
  return true;
}

}  // namespace ovo::factors
