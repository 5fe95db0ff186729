#include "factors/bias_prior_factor.hpp"

#include <algorithm>

namespace ovo::factors {

BiasPriorFactor::BiasPriorFactor(const Vec3& b0_radps, double sigma_radps)
    : b0_radps_(b0_radps), inv_sigma_(1.0 / std::max(sigma_radps, 1e-12)) {}

bool BiasPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Eigen::Map<const Vec3> b(parameters[0]);
  Eigen::Map<Vec3> r(residuals);
  r = inv_sigma_ * (b - b0_radps_);
  if (jacobians != nullptr && jacobians[0] != nullptr)
    Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>{jacobians[0]} =
        inv_sigma_ * Mat3::Identity();
  return true;
}

}  // namespace ovo::factors
