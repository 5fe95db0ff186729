// Ground-plane fit on unit-scale triangulated points: the monocular scale of the plain `vo`
// chain. libviso2 takes the mode of the points' heights along an assumed camera pitch; ovo fits
// the plane (normal and the camera's height over it) by RANSAC + least squares, so the pitch is
// estimated, not assumed (a wrongly assumed pitch makes the scale drift).
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "common/config.hpp"
#include "common/types.hpp"

namespace ovo::estimator {

struct GroundPlaneOptions {
  double max_normal_deviation_deg = 20.0;       // plane normal vs the prior "up" direction
  double max_point_angle_from_down_deg = 88.0;  // candidates: at least 2 deg below the horizon
  double inlier_rel_threshold = 0.04;           // |n.X + d| / d, relative (scale unknown)
  int ransac_iterations = 200;
  int min_inliers = 12;
  std::uint64_t seed = 7;
  bool operator==(const GroundPlaneOptions&) const = default;
};
GroundPlaneOptions readGroundPlaneOptions(const Config& cfg);  // keys under "vo.ground."

struct GroundPlane {
  Vec3 up_C = Vec3(0, -1, 0);  // unit normal pointing from the ground towards the camera
  double height = 0.0;         // camera height over the plane, in the points' (unit) scale
  int inliers = 0;
};

/// Fits the ground plane to points p_C (camera frame, any scale) given the prior up direction in
/// C (from the rig: R_C_B * z_B). Returns nullopt when too few points support a plane.
std::optional<GroundPlane> fitGroundPlane(const std::vector<Vec3>& points_C, const Vec3& up_prior_C,
                                          const GroundPlaneOptions& options);

}  // namespace ovo::estimator
