// Tie between a keyframe's orientation as the camera sees it and as the gyro chain carries it.
#pragma once

#include <ceres/sized_cost_function.h>

#include "common/types.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

/// r = Log(R_W_G^T R_W_B) / sigma: the vision's orientation of a keyframe (R_W_B, the one its
/// bearing, LiDAR and pose factors see) differs from the gyro chain's (R_W_G, the one its gyro
/// factors see) by a rotation of `sigma` rad per axis. It stands for the error the vision makes in
/// one keyframe's orientation as a whole: the tracks' errors are not independent (they creep
/// together, and tracks on depth edges lean one way), so however many tracks a keyframe has, its
/// orientation is not better known than this. Blocks: q_W_B[4], q_W_G[4].
class RotationTieFactor final : public ceres::SizedCostFunction<3, 4, 4> {
 public:
  explicit RotationTieFactor(double sigma_rad);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double inv_sigma_;
};

}  // namespace ovo::factors
