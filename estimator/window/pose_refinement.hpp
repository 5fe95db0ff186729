// Motion-only refinement of one frame's pose against fixed landmarks (the per-frame tracking
// between keyframes), with a rotation prior from the gyro.
#pragma once

#include <optional>
#include <vector>

#include "estimator/window/factors.hpp"

namespace ovo::estimator {

/// Motion-only refinement of one frame pose against landmarks fixed at their current values
/// (world points), with a rotation prior (e.g. from the gyro). cameras_B: the camera's pose in the
/// body for each sighting (a rolling shutter's row, Readout::cameraAt), or empty for the rig's
/// model.T_B_C for all. Returns the pose and, per point, whether it is an inlier (angle error
/// below outlier_rad); nullopt when it fails.
struct PoseRefinement {
  SE3 T_W_B;
  std::vector<char> inlier;
  int num_inliers = 0;
};
std::optional<PoseRefinement> refinePose(const std::vector<Vec3>& points_W,
                                         const std::vector<Vec3>& bearings_C,
                                         const std::vector<SE3>& cameras_B, const SE3& T_W_B_init,
                                         const std::optional<Mat3>& R_W_B_prior,
                                         double prior_sigma_rad, const WindowModel& model,
                                         int max_iterations, double outlier_rad);

}  // namespace ovo::estimator
