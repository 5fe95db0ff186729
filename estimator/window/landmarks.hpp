// The window's landmarks: made from the tracks a new keyframe shares with an earlier one
// (triangulated into an inverse depth along the earlier, anchoring, keyframe's bearing), and the
// outliers removed after a solve (bearing sightings, landmarks at their depth bounds, LiDAR
// associations).
#pragma once

#include "estimator/window/factors.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// A landmark for every track of kf that has none yet and that an earlier keyframe of the window
/// sees, anchored in the first such keyframe, when the rotation-compensated parallax reaches
/// landmark_min_parallax_deg and the depth is at least landmark_min_depth_m; beyond
/// landmark_max_depth_m it starts as a point at infinity (inverse depth 0).
void triangulateNewLandmarks(WindowMap& map, const Keyframe& kf, const SE3& T_B_C,
                             const WindowOptions& options);

/// After a solve: removes bearing sightings further than outlier_sigmas of their own noise from
/// their prediction (ObservationError::sigmas), landmarks whose anchor no longer sees them or
/// nearer than the inverse-depth bound allows (far ones, at infinity included, stay), and LiDAR
/// associations that disagree with their landmark (lidarOutlier; remembered as rejected).
void removeOutliers(WindowMap& map, const WindowModel& model, const WindowOptions& options);

}  // namespace ovo::estimator
