// Pose prior on one keyframe, e.g. to fix the gauge (position and yaw) of the first keyframe.
#pragma once

#include <ceres/sized_cost_function.h>

#include <limits>

#include "common/types.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

using Mat6 = Eigen::Matrix<double, 6, 6>;

/// r = S [Log(R_W_B R_W_B0^T); p_W_B - p_W_B0], S^T S = information (6x6, rotation first, the
/// rotation error about world axes, so its z component is yaw). The information may be singular
/// (a free roll/pitch): S comes from its eigen-decomposition. Blocks: q_W_B[4], p_W_B[3].
class PosePriorFactor final : public ceres::SizedCostFunction<6, 4, 3> {
 public:
  PosePriorFactor(const SE3& T_W_B0, const Mat6& information);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// Gauge information: position sigma (m), yaw sigma (rad), roll/pitch sigma (rad; infinity =
  /// free).
  static Mat6 gaugeInformation(
      double sigma_position_m, double sigma_yaw_rad,
      double sigma_roll_pitch_rad = std::numeric_limits<double>::infinity());

 private:
  Mat3 R_W_B0_;
  Vec3 p_W_B0_;
  Mat6 sqrt_information_;
};

}  // namespace ovo::factors
