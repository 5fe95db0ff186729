// LiDAR range-to-landmark factors (DESIGN.md section 6): a planar LiDAR beam associated with a
// landmark constrains the landmark's metric distance, which fixes the scale of the window.
#pragma once

#include <ceres/sized_cost_function.h>

#include <optional>

#include "common/types.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

/// What a LiDAR association measures of the landmark point p_L (LiDAR frame): its height
/// ground_up_L . p_L on a ground plane (ground_up_L non-zero), else its distance (in the scan plane
/// when planar). nullopt when the distance vanishes; grad (optional): d value / d p_L. The factors
/// below and the estimator's outlier gate read the measurement through this one function.
std::optional<double> lidarMeasuredValue(Vec3 p_L, bool planar, const Vec3& ground_up_L,
                                         Eigen::RowVector3d* grad = nullptr);

/// A beam of the scan taken at keyframe k (measured range r in m; its angle phi only serves the
/// association) and a landmark anchored in keyframe a (unit bearing b_a in C_a, inverse depth rho):
///   r_res = (||p_L|| - r) / sigma_r,  p_L = T_L_B T_B_W_k T_W_B_a T_B_C (b_a / rho).
/// Blocks: q_W_Ba[4], p_W_Ba[3], q_W_Bk[4], p_W_Bk[3], rho[1]. The residual is ill-conditioned as
/// rho -> 0 (the distance goes to infinity and d/d rho ~ 1/rho^2): the estimator creates these only
/// for landmarks with a sane depth; Evaluate fails (Ceres rejects the step) for rho <= 1e-6.
/// When a == k use LidarRangeAnchorFactor (Ceres forbids one block twice in a residual).
/// planar: the distance in the scan plane, ||(p_L.x, p_L.y)||, for a range interpolated between
/// the beams at the landmark's azimuth (a landmark just off the plane on an upright surface).
/// ground_up_L non-zero (unit): the landmark lies on the ground through a beam end instead,
///   r_res = (up_L . p_L - h) / sigma,  h = up_L . (beam end): range_m carries h (m, negative).
class LidarRangeFactor final : public ceres::SizedCostFunction<1, 4, 3, 4, 3, 1> {
 public:
  LidarRangeFactor(const Vec3& bearing_Ca, double range_m, const SE3& T_B_C, const SE3& T_B_L,
                   double sigma_m, bool planar = false, const Vec3& ground_up_L = Vec3::Zero());
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 bearing_Ca_;
  double range_m_, inv_sigma_;
  Mat3 R_B_C_, R_L_B_;
  Vec3 t_B_C_, t_B_L_;
  bool planar_;
  Vec3 ground_up_L_;
};

/// The same beam when the scan keyframe is the landmark's anchor: the residual depends on rho only,
///   r_res = (||T_L_C (b_a / rho)|| - r) / sigma_r.  Block: rho[1].
class LidarRangeAnchorFactor final : public ceres::SizedCostFunction<1, 1> {
 public:
  LidarRangeAnchorFactor(const Vec3& bearing_Ca, double range_m, const SE3& T_B_C, const SE3& T_B_L,
                         double sigma_m, bool planar = false,
                         const Vec3& ground_up_L = Vec3::Zero());
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 bearing_L_;  // R_L_C b_a
  Vec3 t_L_C_;
  double range_m_, inv_sigma_;
  bool planar_;
  Vec3 ground_up_L_;
};

}  // namespace ovo::factors
