// Bearing step factor: a track's error between two of its sightings after the anchor. Tracked
// features creep (their sub-pixel position random-walks while the track lives), so a track's
// errors against its anchor share the walk; the steps between consecutive sightings do not.
#pragma once

#include <ceres/sized_cost_function.h>

#include "common/types.hpp"
#include "factors/bearing_factor.hpp"

namespace ovo::factors {

/// A landmark anchored in keyframe a (unit bearing b_a in C_a, inverse depth rho), seen with unit
/// bearing b_i from keyframe i and then b_k from keyframe k (both after the anchor):
///   r = T_k ((u_k - b_k) - (u_i - b_i)) / sigma_rad,
/// u_i, u_k the predicted bearings (predictBearing) and T_k the tangent basis of b_k: the change
/// of the bearing error from i to k, in the camera's own axes (where the track's pixel walks).
/// Blocks: q_W_Ba[4], p_W_Ba[3], q_W_Bi[4], p_W_Bi[3], q_W_Bk[4], p_W_Bk[3], rho[1]. Robust loss
/// is added by the caller; Evaluate fails where a prediction vanishes.
class BearingStepFactor final : public ceres::SizedCostFunction<2, 4, 3, 4, 3, 4, 3, 1> {
 public:
  BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci, const Vec3& bearing_Ck,
                    const SE3& T_B_C, double sigma_rad);
  /// The same with a 2x2 square-root information W in BearingFactor::tangentBasis(bearing_Ck)'s
  /// axes (r = W T_k (...)).
  BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci, const Vec3& bearing_Ck,
                    const SE3& T_B_C, const Mat2& sqrt_information);
  /// The same with the camera's pose in the body at each sighting (predictBearing's: a rolling
  /// shutter's rows).
  BearingStepFactor(const Vec3& bearing_Ca, const Vec3& bearing_Ci, const Vec3& bearing_Ck,
                    const SE3& T_B_Ca, const SE3& T_B_Ci, const SE3& T_B_Ck,
                    const Mat2& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 bearing_Ca_, bearing_Ci_;
  Eigen::Matrix<double, 2, 3> tangent_;  // rows t1^T, t2^T of b_k's tangent plane, / sigma
  SE3 T_B_Ca_, T_B_Ci_, T_B_Ck_;
};

}  // namespace ovo::factors
