// The terrain under the robot as a state: each keyframe carries the ground plane in the world
// frame, g = (a, b, c) for the surface z = a x + b y + c, which walks slowly from keyframe to
// keyframe (a hillside's grade changes over metres, not between two keyframes). Ground landmarks
// lie on their anchor keyframe's plane. Unlike the camera-height factor (which holds a point's
// depth along the normal fitted in the anchor's own camera), the plane is shared through the walk
// by every keyframe of the window, so a keyframe whose roll or pitch drifted sees its ground
// points off the terrain: the gyro's roll and pitch drift (a gyro-only rig has no gravity) becomes
// observable wherever the robot drives on ground it can see.
#pragma once

#include <ceres/sized_cost_function.h>

#include "common/types.hpp"

namespace ovo::factors {

/// Signed height of p over the plane g (along its unit normal, positive on the side of +z).
double heightOverTerrain(const Vec3& p, const double* g);
/// The plane g through the point below the camera at camera_height_m along the body's z axis
/// (the ground a robot stands on, before anything else is known of it).
void terrainBelow(const SE3& T_W_B, const SE3& T_B_C, double camera_height_m, double* g);
/// A plane g's change when the positions are scaled about centre (p' = centre + s (p - centre)):
/// g' = M g + k, the slopes kept and the height over the centre scaled by s.
struct TerrainScaling {
  Mat3 M;
  Vec3 k;
};
TerrainScaling terrainScaling(const Vec3& centre, double s);
/// The same plane after the positions are scaled about centre (terrainScaling applied to g).
void scaleTerrain(double* g, const Vec3& centre, double s);

/// A ground landmark anchored in keyframe a (unit bearing b_a in C_a, inverse depth rho) lies on
/// a's terrain plane g: r = height(p_W, g) / sigma, p_W = R_W_Ba (R_B_C b_a / rho + t_B_C) + p_a.
/// Blocks: q_W_Ba[4], p_W_Ba[3], rho[1], g_a[3]. Evaluate fails for rho <= 1e-6.
class TerrainPointFactor final : public ceres::SizedCostFunction<1, 4, 3, 1, 3> {
 public:
  TerrainPointFactor(const Vec3& bearing_Ca, const SE3& T_B_C, double sigma_m);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Vec3 dir_B_;  // R_B_C b_a
  Vec3 t_B_C_;
  double inv_sigma_;
};

/// The terrain's walk between consecutive keyframes i and j over `distance_m` driven:
///   r = [(a_j - a_i) / s_slope, (b_j - b_i) / s_slope, (h_j(m) - h_i(m)) / s_height],
/// h(m) the plane's height at m (the midpoint of the two cameras, x and y), so the offset c does
/// not walk with the distance from the world origin. s_slope = slope_walk sqrt(d),
/// s_height = height_walk sqrt(d), d = max(distance_m, 0.05). Blocks: g_i[3], g_j[3].
class TerrainWalkFactor final : public ceres::SizedCostFunction<3, 3, 3> {
 public:
  TerrainWalkFactor(const Vec3& midpoint_W, double distance_m, double slope_walk,
                    double height_walk);
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Matrix3d J_;  // dr/dg_j = -dr/dg_i
};

}  // namespace ovo::factors
