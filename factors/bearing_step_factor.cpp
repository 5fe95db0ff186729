#include "factors/bearing_step_factor.hpp"

namespace ovo::factors {

BearingStepFactor::BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci,
                                     const Vec3& bearing_Ck, const SE3& T_B_C, double sigma_rad)
    : bearing_Ca_(bearing_Ca.normalized()),
      bearing_Ci_(bearing_Ci.normalized()),
      tangent_(BearingFactor::tangentBasis(bearing_Ck.normalized()) / sigma_rad),
      T_B_Ca_(T_B_C),
      T_B_Ci_(T_B_C),
      T_B_Ck_(T_B_C) {}

BearingStepFactor::BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci,
                                     const Vec3& bearing_Ck, const SE3& T_B_C,
                                     const Mat2& sqrt_information)
    : BearingStepFactor(bearing_Ca, bearing_Ci, bearing_Ck, T_B_C, T_B_C, T_B_C, sqrt_information) {
}

BearingStepFactor::BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci,
                                     const Vec3& bearing_Ck, const SE3& T_B_Ca, const SE3& T_B_Ci,
                                     const SE3& T_B_Ck, const Mat2& sqrt_information)
    : bearing_Ca_(bearing_Ca.normalized()),
      bearing_Ci_(bearing_Ci.normalized()),
      tangent_(sqrt_information * BearingFactor::tangentBasis(bearing_Ck.normalized())),
      T_B_Ca_(T_B_Ca),
      T_B_Ci_(T_B_Ci),
      T_B_Ck_(T_B_Ck) {}

bool BearingStepFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const double rho = parameters[6][0];
  const bool jac = jacobians != nullptr;
  const auto i = predictBearing(bearing_Ca_, T_B_Ca_, T_B_Ci_, parameters[0], parameters[1],
                                parameters[2], parameters[3], rho, jac);
  const auto k = predictBearing(bearing_Ca_, T_B_Ca_, T_B_Ck_, parameters[0], parameters[1],
                                parameters[4], parameters[5], rho, jac);
  if (!i || !k) return false;
  // T_k b_k = 0, so b_k drops out of the residual.
  Eigen::Map<Vec2> r(residuals);
  r = tangent_ * (k->u - i->u + bearing_Ci_);
  if (!jac) return true;
  const Eigen::Matrix<double, 2, 13> Ji = tangent_ * i->J, Jk = tangent_ * k->J;
  using Mat23R = Eigen::Matrix<double, 2, 3, Eigen::RowMajor>;
  if (jacobians[0])
    rotationJacobianToAmbient<2>(Jk.block<2, 3>(0, 0) - Ji.block<2, 3>(0, 0), parameters[0],
                                 jacobians[0]);
  if (jacobians[1]) Eigen::Map<Mat23R>{jacobians[1]} = Jk.block<2, 3>(0, 3) - Ji.block<2, 3>(0, 3);
  if (jacobians[2])
    rotationJacobianToAmbient<2>(-Ji.block<2, 3>(0, 6), parameters[2], jacobians[2]);
  if (jacobians[3]) Eigen::Map<Mat23R>{jacobians[3]} = -Ji.block<2, 3>(0, 9);
  if (jacobians[4]) rotationJacobianToAmbient<2>(Jk.block<2, 3>(0, 6), parameters[4], jacobians[4]);
  if (jacobians[5]) Eigen::Map<Mat23R>{jacobians[5]} = Jk.block<2, 3>(0, 9);
  if (jacobians[6]) Eigen::Map<Vec2>{jacobians[6]} = Jk.col(12) - Ji.col(12);
  return true;
}

}  // namespace ovo::factors
