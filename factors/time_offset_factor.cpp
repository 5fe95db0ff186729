#include "factors/time_offset_factor.hpp"

#include <algorithm>

#include "common/so3.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

bool GyroTimeOffsetFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Mat3 R_W_Bi = quatFromBlock(parameters[0]).toRotationMatrix();
  const Mat3 R_W_Bj = quatFromBlock(parameters[1]).toRotationMatrix();
  const Eigen::Map<const Vec3> b_g(parameters[2]);
  const double td = parameters[3][0];

  const double d = td_lin_s_ - td;  // the interval's shift from the preintegration's
  const Vec3 w_i = preint_->rateAtStart() - b_g;
  const Vec3 w_j = preint_->rateAtEnd() - b_g;
  const Vec3 phi_b = preint_->biasJacobian() * (b_g - preint_->biasLinearization());
  const Mat3 dR_b = preint_->deltaR() * so3::exp(phi_b);
  const Mat3 A = R_W_Bi.transpose() * R_W_Bj;
  // E = Exp(-w_j d) dR_b^T Exp(w_i d) A = Exp(-w_j d) M.
  const Mat3 M = dR_b.transpose() * so3::exp(w_i * d) * A;
  const Mat3 E = so3::exp(-w_j * d) * M;
  const Vec3 r = so3::log(E);
  const Mat3& S = preint_->sqrtInformation();
  Eigen::Map<Vec3> residual(residuals);
  residual = S * r;
  if (!jacobians) return true;

  // Right perturbations E <- E Exp(phi), each worked out by moving the perturbed factor to the
  // right end (Exp(v) X = X Exp(X^T v)); dr = S Jr^-1(r) phi.
  const Mat3 S_Jinv = S * so3::rightJacobianInverse(r);
  if (jacobians[0]) {  // R_W_Bi <- Exp(theta) R_W_Bi: phi = -R_W_Bj^T theta
    rotationJacobianToAmbient<3>(Mat3(-S_Jinv * R_W_Bj.transpose()), parameters[0], jacobians[0]);
  }
  if (jacobians[1]) {  // R_W_Bj <- Exp(theta) R_W_Bj: phi = R_W_Bj^T theta
    rotationJacobianToAmbient<3>(Mat3(S_Jinv * R_W_Bj.transpose()), parameters[1], jacobians[1]);
  }
  if (jacobians[2]) {
    // b_g moves dR_b (through J_b) and both end rates (w = rate - b_g).
    const Mat3 from_end = M.transpose() * so3::rightJacobian(-w_j * d) * d;
    const Mat3 from_preint = -M.transpose() * so3::rightJacobian(phi_b) * preint_->biasJacobian();
    const Mat3 from_start = -A.transpose() * so3::rightJacobian(w_i * d) * d;
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> J(jacobians[2]);
    J = S_Jinv * (from_end + from_preint + from_start);
  }
  if (jacobians[3]) {  // d = td_lin - td: phi = (A^T w_i - E^T w_j) dd, dd = -dtd
    Eigen::Map<Vec3> J(jacobians[3]);
    J = -S_Jinv * (A.transpose() * w_i - E.transpose() * w_j);
  }
  return true;
}

}  // namespace ovo::factors
