// A robust loss applied as Ceres applies it (ceres/corrector.cc, Triggs et al.): the residual and
// its Jacobian rescaled so that J^T J and J^T r are the Gauss-Newton terms of rho(|r|^2) / 2. The
// window's own minimiser and the marginalisation prior both linearise the window's factors this
// way, so that they see what Ceres' solve sees.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace ovo::factors {

class RobustCorrection {
 public:
  /// sq_norm = |r|^2 of the uncorrected residual, rho = the loss at it (value, first and second
  /// derivative).
  RobustCorrection(double sq_norm, const double rho[3])
      : sqrt_rho1_(std::sqrt(std::max(rho[1], 0.0))), residual_scaling_(sqrt_rho1_) {
    if (sq_norm > 0.0 && rho[2] > 0.0 && rho[1] > 0.0) {
      const double alpha = 1.0 - std::sqrt(1.0 + 2.0 * sq_norm * rho[2] / rho[1]);
      residual_scaling_ = sqrt_rho1_ / (1.0 - alpha);
      alpha_sq_norm_ = alpha / sq_norm;
    }
  }

  /// J <- sqrt(rho') (J - alpha / |r|^2 r r^T J), with r the uncorrected residual: call before
  /// correctResidual.
  template <typename Jacobian, typename Residual>
  void correctJacobian(Jacobian&& J, const Residual& r) const {
    if (alpha_sq_norm_ != 0.0)
      J = sqrt_rho1_ * (J - alpha_sq_norm_ * r * (r.transpose() * J));
    else
      J *= sqrt_rho1_;
  }

  template <typename Residual>
  void correctResidual(Residual&& r) const {
    r *= residual_scaling_;
  }

 private:
  double sqrt_rho1_;
  double residual_scaling_;
  double alpha_sq_norm_ = 0.0;
};

}  // namespace ovo::factors
