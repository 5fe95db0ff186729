#include "factors/scalar_prior_factor.hpp"

#include <algorithm>

namespace ovo::factors {

ScalarPriorFactor::ScalarPriorFactor(double x0, double sigma)
    : x0_(x0), inv_sigma_(1.0 / std::max(sigma, 1e-12)) {}

bool ScalarPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  residuals[0] = inv_sigma_ * (parameters[0][0] - x0_);
  if (jacobians && jacobians[0]) jacobians[0][0] = inv_sigma_;
  return true;
}

}  // namespace ovo::factors
