// Basic types shared by every ovo module: time stamps, Eigen aliases and stamped poses.
// Conventions (DESIGN.md section 2): time is int64 nanoseconds; T_A_B maps B coordinates into A
// (p_A = T_A_B * p_B); camera frame x right, y down, z forward.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace ovo {

using Timestamp = std::int64_t;  // nanoseconds

constexpr double kNsPerSec = 1e9;
inline double toSeconds(Timestamp t_ns) { return static_cast<double>(t_ns) * 1e-9; }
inline Timestamp fromSeconds(double t_s) {
  return static_cast<Timestamp>(t_s * 1e9 + (t_s >= 0 ? 0.5 : -0.5));
}

using Vec2 = Eigen::Vector2d;
using Vec3 = Eigen::Vector3d;
using Mat2 = Eigen::Matrix2d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
using SE3 = Eigen::Isometry3d;  // rigid transform T_A_B

/// A pose T_W_B at a time.
struct StampedPose {
  Timestamp t_ns = 0;
  SE3 T_W_B = SE3::Identity();
};
using Trajectory = std::vector<StampedPose>;

/// One gyro (and accelerometer) sample in the body frame B.
struct ImuSample {
  Timestamp t_ns = 0;
  Vec3 gyro_radps = Vec3::Zero();
  Vec3 accel_mps2 = Vec3::Zero();
};

/// One planar LiDAR scan in the LiDAR frame L: beam i has angle angle_min + i * angle_increment
/// in the x-y plane of L (x forward at angle 0); a range outside [range_min, range_max] (or NaN)
/// is no return. Beam i is taken at t_ns + i * time_increment_s (ROS LaserScan's stamp and
/// time_increment: the stamp is the first beam's time); time_increment_s = 0: instantaneous.
struct LidarScan {
  Timestamp t_ns = 0;
  double angle_min_rad = 0.0;
  double angle_increment_rad = 0.0;
  double range_min_m = 0.0;
  double range_max_m = 0.0;
  std::vector<double> ranges_m;
  double time_increment_s = 0.0;  // beam i measured at t_ns + i * time_increment_s (0: at t_ns)

  bool valid(std::size_t i) const {
    const double r = ranges_m[i];
    return r == r && r >= range_min_m && r <= range_max_m;
  }
  double angle(std::size_t i) const {
    return angle_min_rad + static_cast<double>(i) * angle_increment_rad;
  }
  /// End point of beam i in L (z = 0 plane).
  Vec3 point_L(std::size_t i) const {
    const double a = angle(i);
    return Vec3(ranges_m[i] * std::cos(a), ranges_m[i] * std::sin(a), 0.0);
  }
};

inline bool allFinite(const SE3& T) { return T.matrix().allFinite(); }

}  // namespace ovo
