#include "factors/bearing_factor.hpp"

#include <cmath>

#include "common/so3.hpp"

namespace ovo::factors {

BearingFactor::BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_C,
                             double sigma_rad)
    : bearing_Ca_(bearing_Ca.normalized()),
      tangent_(tangentBasis(bearing_Cj.normalized()) / sigma_rad),
      T_B_Ca_(T_B_C),
      T_B_Cj_(T_B_C) {}

BearingFactor::BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_C,
                             const Mat2& sqrt_information)
    : BearingFactor(bearing_Ca, bearing_Cj, T_B_C, T_B_C, sqrt_information) {}

BearingFactor::BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_Ca,
                             const SE3& T_B_Cj, const Mat2& sqrt_information)
    : bearing_Ca_(bearing_Ca.normalized()),
      tangent_(sqrt_information * tangentBasis(bearing_Cj.normalized())),
      T_B_Ca_(T_B_Ca),
      T_B_Cj_(T_B_Cj) {}

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

std::optional<PredictedBearing> predictBearing(const Vec3& bearing_Ca, const Mat3& R_B_C,
                                               const Vec3& t_B_C, const double* q_W_Ba,
                                               const double* p_W_Ba, const double* q_W_Bj,
                                               const double* p_W_Bj, double rho, bool jacobian) {
  SE3 T_B_C = SE3::Identity();
  T_B_C.linear() = R_B_C;
  T_B_C.translation() = t_B_C;
  return predictBearing(bearing_Ca, T_B_C, T_B_C, q_W_Ba, p_W_Ba, q_W_Bj, p_W_Bj, rho, jacobian);
}

std::optional<PredictedBearing> predictBearing(const Vec3& bearing_Ca, const SE3& T_B_Ca,
                                               const SE3& T_B_Cj, const double* q_W_Ba,
                                               const double* p_W_Ba, const double* q_W_Bj,
                                               const double* p_W_Bj, double rho, bool jacobian) {
  const Eigen::Map<const Vec3> p_a(p_W_Ba), p_j(p_W_Bj);
  const Mat3 R_W_Ba = quatFromBlock(q_W_Ba).toRotationMatrix();
  const Mat3 R_W_Bj = quatFromBlock(q_W_Bj).toRotationMatrix();
  const Mat3 R_C_B = T_B_Cj.linear().transpose();
  const Mat3 R_C_W = R_C_B * R_W_Bj.transpose();
  const Vec3 t_B_Ca = T_B_Ca.translation(), t_B_Cj = T_B_Cj.translation();

  const Vec3 v_Ba = T_B_Ca.linear() * bearing_Ca + rho * t_B_Ca;  // rho * p_Ba
  const Vec3 Rv_W = R_W_Ba * v_Ba;
  const Vec3 w_W = Rv_W + rho * (p_a - p_j);  // rho * (p_W - p_W_Bj)
  const Vec3 h = R_C_W * w_W - rho * (R_C_B * t_B_Cj);
  const double n = h.norm();
  if (!(n > 1e-12)) return std::nullopt;
  PredictedBearing out;
  out.u = h / n;
  if (!jacobian) return out;

  // d u / d h = (I - u u^T) / |h|
  const Mat3 du_dh = (Mat3::Identity() - out.u * out.u.transpose()) / n;
  const Mat3 A = du_dh * R_C_W;
  out.J.block<3, 3>(0, 0) = A * (-so3::hat(Rv_W));
  out.J.block<3, 3>(0, 3) = rho * A;
  out.J.block<3, 3>(0, 6) = A * so3::hat(w_W);
  out.J.block<3, 3>(0, 9) = -rho * A;
  out.J.col(12) = A * (R_W_Ba * t_B_Ca + p_a - p_j) - du_dh * (R_C_B * t_B_Cj);
  return out;
}

bool BearingFactor::Evaluate(double const* const* parameters, double* residuals,
                             double** jacobians) const {
  const auto b =
      predictBearing(bearing_Ca_, T_B_Ca_, T_B_Cj_, parameters[0], parameters[1], parameters[2],
                     parameters[3], parameters[4][0], jacobians != nullptr);
  if (!b) return false;
  Eigen::Map<Vec2> r(residuals);
  r = tangent_ * b->u;
  if (!jacobians) return true;
  const Eigen::Matrix<double, 2, 13> J = tangent_ * b->J;
  if (jacobians[0]) rotationJacobianToAmbient<2>(J.block<2, 3>(0, 0), parameters[0], jacobians[0]);
  using Mat23R = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;
  if (jacobians[1]) Eigen::Map<Mat23R>{jacobians[1]} = J.block<2, 3>(0, 3);
  if (jacobians[2]) rotationJacobianToAmbient<2>(J.block<2, 3>(0, 6), parameters[2], jacobians[2]);
  if (jacobians[3]) Eigen::Map<Mat23R>{jacobians[3]} = J.block<2, 3>(0, 9);
  if (jacobians[4]) Eigen::Map<Vec2>{jacobians[4]} = J.col(12);
  return true;
}

}  // namespace ovo::factors
