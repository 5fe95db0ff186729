// A LiDAR association's noise, its residual against a landmark's point, and the gate that
// rejects it as an outlier (the window's solve, outlier pass and residual statistics use these).
#pragma once

#include <optional>

#include "common/types.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/model.hpp"

namespace ovo::estimator {

/// The noise of association a's measurement (m): lidar_sigma_m for a range; for a ground-plane
/// association (ground_up_L non-zero), the beam's range noise seen off the plane
/// (lidar_range_sigma_m * ground_sin: a beam meeting the ground at a grazing angle pins the plane's
/// height far better than its range) and the ground's own departure from the plane
/// (lidar_ground_sigma_m), in quadrature.
double lidarSigma(const LidarAssociation& a, const WindowModel& model);

/// The predicted minus the measured value of association a (m): the range to the landmark point
/// p_W seen from where kf's scan was taken (kf.T_B_L; in the scan plane when planar), or its
/// height off the ground-beam plane; nullopt when the point sits on the LiDAR.
std::optional<double> lidarResidualM(const LidarAssociation& a, const Vec3& p_W,
                                     const Keyframe& kf);

/// The window's LiDAR gate: true when the range association a of keyframe kf measured and the
/// range to the landmark point p_W, seen from where kf's scan was taken (kf.T_B_L; in the scan
/// plane when planar), differ by more than max(gate_sigmas * lidar_sigma_m, gate_fraction *
/// range); for a ground-plane association, when the landmark's height off that plane exceeds
/// gate_sigmas * lidarSigma(a).
bool lidarOutlier(const LidarAssociation& a, const Vec3& p_W, const Keyframe& kf,
                  const WindowModel& model, double gate_sigmas, double gate_fraction);

}  // namespace ovo::estimator
