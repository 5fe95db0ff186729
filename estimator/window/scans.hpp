// Which LiDAR scan goes with a camera frame, and where the LiDAR was when it took it: the scan at
// the frame's time, else the latest one a little older, placed by the gyro's rotation and the
// motion in between (a LiDAR out of step with the camera).
#pragma once

#include <functional>
#include <optional>
#include <vector>

#include "common/types.hpp"
#include "estimator/window/frame_log.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// A scan for a frame, and the LiDAR's pose when it took it in that frame's body frame.
struct FrameScan {
  const LidarScan* scan = nullptr;
  SE3 T_B_L = SE3::Identity();
};

/// The scan chosen for a frame, before it is placed: the scan at the frame (R_Bscan_Bframe
/// nullopt), or an older one with the gyro's rotation from it to the frame.
struct ScanChoice {
  const LidarScan* scan = nullptr;
  std::optional<Mat3> R_Bscan_Bframe;
};

class ScanTimeline {
 public:
  /// The gyro's rotation R_B0_B1 from t0 to t1 when it covers the interval without a gap.
  using GyroRotation = std::function<std::optional<Mat3>(Timestamp t0_ns, Timestamp t1_ns)>;

  explicit ScanTimeline(const WindowOptions& options)
      : tol_(fromSeconds(options.lidar_scan_time_tol_s)),
        max_age_s_(options.lidar_scan_max_age_s) {}

  /// Adds a scan stamped on the gyro clock, placed on the images' timeline by the current shift,
  /// and forgets those older than keep_from (keeping at least two).
  void add(LidarScan scan, Timestamp keep_from_ns);
  /// Places every scan on the images' timeline by `shift_ns` (image time = gyro time + shift):
  /// the newest estimate of the time offset, for the scans that came before it too.
  void setShift(Timestamp shift_ns);
  /// The scan within lidar_scan_time_tol_s of t (the nearest), or null.
  const LidarScan* at(Timestamp t_ns) const;
  /// The scan at t, else the latest one before it up to lidar_scan_max_age_s older whose rotation
  /// to t the gyro gives; nullopt when none.
  std::optional<ScanChoice> choose(Timestamp t_ns, const GyroRotation& gyro) const;
  /// The chosen scan placed in the frame at t (body pose T_W_B, velocity v_W): an older scan's
  /// LiDAR pose is turned back by the gyro's rotation and moved to the body position at the scan
  /// (interpolated between the frames around it in `frames`, else moved back by the velocity).
  /// Before initialisation those positions are not yet metric: an older scan there carries the
  /// motion over its age as an error (1.6 cm at 0.8 m/s and 20 ms).
  std::optional<FrameScan> scanFor(Timestamp t_ns, const SE3& T_W_B, const Vec3& v_W,
                                   const FrameLog& frames, const SE3& T_B_L,
                                   const GyroRotation& gyro) const;
  /// Whether the frame after the one at t (one frame period, t - last_t, on) is expected to come
  /// with a scan: the first buffered scan after t, or else the last scan plus the last scan
  /// period, falls on it.
  bool expectedAfter(Timestamp t_ns, Timestamp last_t_ns) const;

 private:
  Timestamp tol_;
  double max_age_s_;
  std::vector<LidarScan> scans_;  // recent scans, in time order, on the images' timeline
  Timestamp shift_ = 0;
};

}  // namespace ovo::estimator
