// Prior on one gyro bias: the first keyframe's bias prior, a zero-rate update from a standstill.
#pragma once

#include <ceres/sized_cost_function.h>

#include "common/types.hpp"

namespace ovo::factors {

/// r = (b_g - b_0) / sigma per axis; sigma in rad/s (> 0). Block: b_g[3] (rad/s).
class BiasPriorFactor final : public ceres::SizedCostFunction<3, 3> {
 public:
  BiasPriorFactor(const Vec3& b0_radps, double sigma_radps);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 b0_radps_;
  double inv_sigma_;  // s/rad
};

}  // namespace ovo::factors
