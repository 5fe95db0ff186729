#include "factors/ground_height_factor.hpp"

#include <algorithm>
#include <cmath>

namespace ovo::factors {

GroundHeightFactor::GroundHeightFactor(const Vec3& bearing_Ca, const Vec3& up_Ca,
                                       double camera_height_m, double sigma_m)
    : down_(-up_Ca.normalized().dot(bearing_Ca.normalized())),
      height_m_(camera_height_m),
      inv_sigma_(1.0 / sigma_m) {}

bool GroundHeightFactor::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const double rho = parameters[0][0];
  if (!(rho > 1e-6) || !(down_ > 0.0)) return false;
  residuals[0] = (down_ / rho - height_m_) * inv_sigma_;
  if (jacobians && jacobians[0]) jacobians[0][0] = -inv_sigma_ * down_ / (rho * rho);
  return true;
}

GroundHeightCorrectedFactor::GroundHeightCorrectedFactor(const Vec3& bearing_Ca, const Vec3& up_Ca,
                                                         double camera_height_m, double sigma_m)
    : plain_(bearing_Ca, up_Ca, camera_height_m, sigma_m), inv_sigma_(1.0 / sigma_m) {}

bool GroundHeightCorrectedFactor::Evaluate(double const* const* parameters, double* residuals,
                                           double** jacobians) const {
  double* plain_jacobians[1] = {jacobians ? jacobians[0] : nullptr};
  if (!plain_.Evaluate(parameters, residuals, jacobians ? plain_jacobians : nullptr)) return false;
  residuals[0] -= parameters[1][0] * inv_sigma_;
  if (jacobians && jacobians[1]) jacobians[1][0] = -inv_sigma_;
  return true;
}

CameraHeightWalkFactor::CameraHeightWalkFactor(double distance_m, double sigma_m, double length_m) {
  // A floor of 0.1 mm driven: two keyframes at one place are tied tightly, not infinitely.
  constexpr double kMinDistanceM = 1e-4;
  const double x = std::max(distance_m, kMinDistanceM) / length_m;
  a_ = std::exp(-x);
  inv_sigma_ = 1.0 / (sigma_m * std::sqrt(-std::expm1(-2.0 * x)));  // 1 - a^2 without cancellation
}

bool CameraHeightWalkFactor::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  residuals[0] = (parameters[1][0] - a_ * parameters[0][0]) * inv_sigma_;
  if (jacobians) {
    if (jacobians[0]) jacobians[0][0] = -a_ * inv_sigma_;
    if (jacobians[1]) jacobians[1][0] = inv_sigma_;
  }
  return true;
}

}  // namespace ovo::factors
