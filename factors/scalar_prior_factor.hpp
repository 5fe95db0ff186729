// A prior on one scalar state: the camera-gyro time offset about the rig's value, the camera
// height's correction about 0 (states of the whole window that no keyframe holds).
#pragma once

#include <ceres/sized_cost_function.h>

namespace ovo::factors {

/// r = (x - x0) / sigma (sigma > 0, in x's unit). Block: x[1].
class ScalarPriorFactor final : public ceres::SizedCostFunction<1, 1> {
 public:
  ScalarPriorFactor(double x0, double sigma);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double x0_;
  double inv_sigma_;
};

}  // namespace ovo::factors
