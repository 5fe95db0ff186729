// Camera-height factor: a landmark on the ground near the camera lies the known camera height
// below it along the ground normal, which fixes the metric scale where the LiDAR sees little
// (the window's version of the vo chain's ground-plane scale, DESIGN sections 4 and 7).
#pragma once

#include <ceres/sized_cost_function.h>

#include "common/types.hpp"

namespace ovo::factors {

/// A landmark anchored in keyframe a (unit bearing b_a in C_a, inverse depth rho) on the ground,
/// whose normal in C_a is up_Ca (unit, pointing from the ground to the camera):
///   r = (-(up_Ca . b_a) / rho - h) / sigma_h,
/// the point's depth below the camera along the normal minus the camera height h (m).
/// Block: rho[1]. Evaluate fails for rho <= 1e-6 or a bearing that does not point below the
/// horizon (up_Ca . b_a >= 0).
class GroundHeightFactor final : public ceres::SizedCostFunction<1, 1> {
 public:
  GroundHeightFactor(const Vec3& bearing_Ca, const Vec3& up_Ca, double camera_height_m,
                     double sigma_m);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double down_;  // -(up_Ca . b_a): the cosine of the bearing with the downward normal
  double height_m_, inv_sigma_;
};

/// The same with a correction dh of the camera height as a state (the camera's height above the
/// ground it sees differs from the rig's on rough ground: the LiDAR measures it):
///   r = (-(up_Ca . b_a) / rho - (h + dh)) / sigma_h.
/// Blocks: rho[1], dh[1] (m). Evaluate fails as GroundHeightFactor's.
class GroundHeightCorrectedFactor final : public ceres::SizedCostFunction<1, 1, 1> {
 public:
  GroundHeightCorrectedFactor(const Vec3& bearing_Ca, const Vec3& up_Ca, double camera_height_m,
                              double sigma_m);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  GroundHeightFactor plain_;
  double inv_sigma_;
};

/// The camera-height correction along the path (WindowModel::camera_height_path_sigma_m): a
/// first-order Gauss-Markov process in the distance driven, stationary standard deviation sigma
/// (m) and correlation length L (m). Between keyframes d metres apart, with a = exp(-d / L):
///   r = (dh_j - a dh_i) / (sigma sqrt(1 - a^2)),
/// so that the correction wanders with the ground, by sigma sqrt(2 d / L) over a short d, but not
/// while the robot stands (d = 0 ties the two, up to a floor of 0.1 mm on the distance).
/// Blocks: dh_i[1], dh_j[1] (m).
class CameraHeightWalkFactor final : public ceres::SizedCostFunction<1, 1, 1> {
 public:
  CameraHeightWalkFactor(double distance_m, double sigma_m, double length_m);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double a_, inv_sigma_;
};

}  // namespace ovo::factors
