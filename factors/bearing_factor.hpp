// Bearing factor (DESIGN.md section 6): a landmark anchored in keyframe a (unit bearing b_a in C_a,
// inverse depth rho) observed from keyframe j with measured unit bearing b_j.
#pragma once

#include <ceres/sized_cost_function.h>

#include <optional>

#include "common/types.hpp"
#include "factors/parameterization.hpp"

namespace ovo::factors {

/// The predicted unit bearing u in C_j of a landmark anchored in keyframe a (unit bearing b_a in
/// C_a, inverse depth rho) and, on request, du/d[theta_a, p_a, theta_j, p_j, rho] (3 x 13; theta
/// are world-frame rotation vectors, R <- Exp(theta) R). u is taken from the homogeneous point
///   h = R_C_B R_W_Bj^T ( R_W_Ba (R_B_C b_a + rho t_B_C) + rho (p_W_Ba - p_W_Bj) ) - rho R_C_B
///   t_B_C = rho p_Cj,
/// which stays finite at rho -> 0 (a point at infinity). nullopt when h vanishes.
struct PredictedBearing {
  Vec3 u;
  // Zero unless asked for: the optional's move copies it, and must not read indeterminate values.
  Eigen::Matrix<double, 3, 13> J = Eigen::Matrix<double, 3, 13>::Zero();
};
std::optional<PredictedBearing> predictBearing(const Vec3& bearing_Ca, const Mat3& R_B_C,
                                               const Vec3& t_B_C, const double* q_W_Ba,
                                               const double* p_W_Ba, const double* q_W_Bj,
                                               const double* p_W_Bj, double rho, bool jacobian);
/// The same with the camera's pose in the body at each sighting, T_B_Ca at the anchor's and T_B_Cj
/// at keyframe j's (a rolling shutter's row: the rig's T_B_C moved by the body's motion from the
/// keyframe's time to the row's; the Jacobian holds them fixed).
std::optional<PredictedBearing> predictBearing(const Vec3& bearing_Ca, const SE3& T_B_Ca,
                                               const SE3& T_B_Cj, const double* q_W_Ba,
                                               const double* p_W_Ba, const double* q_W_Bj,
                                               const double* p_W_Bj, double rho, bool jacobian);

/// Residual = [t1 t2]^T u / sigma_rad, where u is the predicted unit bearing of the landmark in C_j
/// (predictBearing) and (t1, t2) an orthonormal basis of the tangent plane of the measured bearing
/// b_j (computed once). The residual is zero for u = -b_j too:
/// the estimator gates observations with predictBearing(...).u.dot(b_j) > 0.
/// Blocks: q_W_Ba[4], p_W_Ba[3], q_W_Bj[4], p_W_Bj[3], rho[1]. Robust loss is added by the caller.
class BearingFactor final : public ceres::SizedCostFunction<2, 4, 3, 4, 3, 1> {
 public:
  /// bearing_Ca, bearing_Cj: unit vectors; sigma_rad: angular noise (about pixel sigma / focal px).
  BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_C, double sigma_rad);
  /// The same with a 2x2 square-root information W in tangentBasis(bearing_Cj)'s axes (the
  /// residual is W [t1 t2]^T u): e.g. the camera's pixels per radian there over the pixel sigma,
  /// which whitens the residual as the image error in pixels would be.
  BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_C,
                const Mat2& sqrt_information);
  /// The same with the camera's pose in the body at each sighting (predictBearing's T_B_Ca,
  /// T_B_Cj).
  BearingFactor(const Vec3& bearing_Ca, const Vec3& bearing_Cj, const SE3& T_B_Ca,
                const SE3& T_B_Cj, const Mat2& sqrt_information);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// Angular sigma from a pixel sigma and the local focal length in pixels (rad).
  static double sigmaRadFromPixels(double sigma_px, double focal_px) { return sigma_px / focal_px; }

  /// Two unit vectors orthogonal to the unit vector b and to each other (rows of the result).
  static Eigen::Matrix<double, 2, 3> tangentBasis(const Vec3& b);

 private:
  Vec3 bearing_Ca_;
  Eigen::Matrix<double, 2, 3> tangent_;  // rows t1^T, t2^T of b_j's tangent plane, / sigma
  SE3 T_B_Ca_, T_B_Cj_;
};

}  // namespace ovo::factors
