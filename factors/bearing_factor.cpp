#include "factors/bearing_factor.hpp"

#include <cmath>

#include "common/so3.hpp"

namespace ovo::factors {

BearingFactor::BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_C,
                             double sigma_rad)
    : bearing_Ca_(bearing_Ca.normalized()),
      tangent_(tangentBasis(bearing_Cj.normalized()) / sigma_rad),
      R_B_C_(T_B_C.rotation()),
      t_B_C_(T_B_C.translation()) {}

Eigen::Matrix<double, 2, 3> BearingFactor::tangentBasis(const Vec3& b) {
  // Start from the coordinate axis least aligned with b, so the cross product is well conditioned.
  Vec3 axis = Vec3::Zero();
  int i_min = 0;
  b.cwiseAbs().minCoeff(&i_min);
  axis[i_min] = 1.0;
  const Vec3 t1 = b.cross(axis).normalized();
  const Vec3 t2 = b.cross(t1);
  Eigen::Matrix<double, 2, 3> T;
  T.row(0) = t1.transpose();
  T.row(1) = t2.transpose();
  return T;
}

std::optional<Vec3> BearingFactor::predictedBearing(const double* q_W_Ba, const double* p_W_Ba,
                                                    const double* q_W_Bj, const double* p_W_Bj,
                                                    double rho) const {
  const Mat3 R_W_Ba = quatFromBlock(q_W_Ba).toRotationMatrix();
  const Mat3 R_W_Bj = quatFromBlock(q_W_Bj).toRotationMatrix();
  const Eigen::Map<const Vec3> p_a(p_W_Ba), p_j(p_W_Bj);
  const Mat3 R_C_B = R_B_C_.transpose();
  const Vec3 h = R_C_B * (R_W_Bj.transpose() *
                              (R_W_Ba * (R_B_C_ * bearing_Ca_ + rho * t_B_C_) + rho * (p_a - p_j)) -
                          rho * t_B_C_);
  const double n = h.norm();
  if (!(n > 1e-12)) return std::nullopt;
  return h / n;
}

bool BearingFactor::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const double* q_a = parameters[0];
  const double* q_j = parameters[2];
  const Eigen::Map<const Vec3> p_a(parameters[1]), p_j(parameters[3]);
  const double rho = parameters[4][0];

  const Mat3 R_W_Ba = quatFromBlock(q_a).toRotationMatrix();
  const Mat3 R_W_Bj = quatFromBlock(q_j).toRotationMatrix();
  const Mat3 R_C_B = R_B_C_.transpose();
  const Mat3 R_C_W = R_C_B * R_W_Bj.transpose();

  const Vec3 v_Ba = R_B_C_ * bearing_Ca_ + rho * t_B_C_;  // rho * p_Ba
  const Vec3 Rv_W = R_W_Ba * v_Ba;
  const Vec3 w_W = Rv_W + rho * (p_a - p_j);  // rho * (p_W - p_W_Bj)
  const Vec3 h = R_C_W * w_W - rho * (R_C_B * t_B_C_);
  const double n = h.norm();
  if (!(n > 1e-12)) return false;
  const Vec3 u = h / n;

  Eigen::Map<Vec2> r(residuals);
  r = tangent_ * u;
  if (!jacobians) return true;

  // d r / d h = T (I - u u^T) / |h|
  const Eigen::Matrix<double, 2, 3> dr_dh = tangent_ * (Mat3::Identity() - u * u.transpose()) / n;
  if (jacobians[0]) {
    const Eigen::Matrix<double, 2, 3> J_theta = dr_dh * R_C_W * (-so3::hat(Rv_W));
    rotationJacobianToAmbient<2>(J_theta, q_a, jacobians[0]);
  }
  if (jacobians[1]) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J(jacobians[1]);
    J = rho * dr_dh * R_C_W;
  }
  if (jacobians[2]) {
    const Eigen::Matrix<double, 2, 3> J_theta = dr_dh * R_C_W * so3::hat(w_W);
    rotationJacobianToAmbient<2>(J_theta, q_j, jacobians[2]);
  }
  if (jacobians[3]) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> J(jacobians[3]);
    J = -rho * dr_dh * R_C_W;
  }
  if (jacobians[4]) {
    const Vec3 dh_drho = R_C_W * (R_W_Ba * t_B_C_ + p_a - p_j) - R_C_B * t_B_C_;
    Eigen::Map<Vec2> J(jacobians[4]);
    J = dr_dh * dh_drho;
  }
  return true;
}

}  // namespace ovo::factors
