// A swept LiDAR scan made instantaneous: each beam, taken at t_scan + i * time_increment from where
// the LiDAR was then, is moved to the LiDAR's pose at the scan's stamp and the scan resampled on
// its own angle grid, so that everything downstream (association, ground beams, the range factors)
// reads it as a scan taken at once at its stamp. A ROS LaserScan's stamp is its first beam's time.
#pragma once

#include <functional>
#include <span>
#include <utility>

#include "common/types.hpp"

namespace ovo::estimator {

/// The LiDAR's pose at tau seconds after the scan's stamp, in its pose at the stamp: T_L0_Ltau.
using LidarMotion = std::function<SE3(double tau_s)>;

/// The LiDAR's motion from the body's: the body turned by R_B0_B(tau) (the gyro) and moved at
/// v_B0 (its velocity in the body frame at the stamp), the LiDAR mounted at T_B_L.
LidarMotion lidarMotionFromBody(const std::function<Mat3(double tau_s)>& R_B0_B, const Vec3& v_B0,
                                const SE3& T_B_L);

/// The scan as if taken at once at its stamp, from the LiDAR's motion over the sweep. Each valid
/// beam's end point is moved into the stamp's LiDAR frame and projected onto its scan plane (the
/// motion out of the plane is dropped: a planar scan holds no more); each angle of the grid then
/// takes the range of the moved beams on either side of it, interpolated, or the nearer one's
/// when they differ by more than max_step_fraction of it (a depth edge between them: no range
/// across the gap). A grid angle whose neighbours are more than 1.5 increments apart (a dropped
/// beam) takes a moved beam within half an increment, else is left invalid (NaN).
/// A scan without per-beam times (time_increment 0) is returned as it is.
LidarScan deskewScan(const LidarScan& scan, const LidarMotion& motion,
                     double max_step_fraction = 0.05);

/// The time a scan's beams span, [first beam, last beam] (its stamp for a scan without per-beam
/// times).
std::pair<Timestamp, Timestamp> sweepInterval(const LidarScan& scan);

/// The body's mean rate over a scan's sweep from raw gyro samples: the mean of the samples inside
/// the sweep less bias_radps; without one inside, the nearest sample's. Zero without samples.
Vec3 meanSweepRate(const LidarScan& scan, std::span<const ImuSample> gyro, const Vec3& bias_radps);

/// The scan made instantaneous at its stamp with the body turning at meanSweepRate and moving at
/// v_B (its velocity in the body frame; zero: the turn alone, the LiDAR's lever arm included).
LidarScan deskewScanWithGyro(const LidarScan& scan, std::span<const ImuSample> gyro,
                             const Vec3& bias_radps, const Vec3& v_B, const SE3& T_B_L);

}  // namespace ovo::estimator
