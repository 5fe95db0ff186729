// ovo's public API: visual odometry for a ground robot from one (fisheye) camera, a gyroscope and
// a planar LiDAR. This is the one header an installed ovo gives (`#include <ovo/ovo.hpp>`, CMake:
// `find_package(ovo REQUIRED)` and `target_link_libraries(app PRIVATE ovo::ovo)`).
//
//   ovo::Odometry odo("rig.yaml", {}, [](const ovo::Pose& p) { ... });
//   odo.addGyro({t_ns, wx, wy, wz});   // body frame, rad/s, as they arrive
//   odo.addScan(scan);                 // sensor_msgs/LaserScan's fields
//   odo.addImage(t_ns, image);         // 8-bit grey or BGR
//   ...
//   odo.finish();                      // poses of every frame: odo.trajectory()
//
// Conventions: time in int64 nanoseconds, the same clock for all sensors. Frames: body B = the
// gyro's frame (x forward, y left, z up), world W = the body frame at the first pose. A pose is
// T_W_B: p_W = R(q) * p_B + position. Camera and LiDAR extrinsics (T_B_C, T_B_L), noise figures and
// the camera calibration come from the rig file.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <stdexcept>
#include <string>
#include <vector>

namespace ovo {

/// The body's pose T_W_B at a camera frame.
struct Pose {
  /// The pose callback's: the image's stamp as given to addImage. trajectory()'s: the time the
  /// image was taken on the gyro's clock: the stamp minus the rig's camera.time_offset_s and,
  /// for the window, minus its own estimate on top of it.
  std::int64_t t_ns = 0;
  /// The time the pose holds on the gyro's (the robot's) clock, what a ROS message's stamp is: the
  /// callback's t_ns less the rig's camera.time_offset_s and, for the window, its own estimate so
  /// far; trajectory()'s t_ns.
  std::int64_t t_gyro_clock_ns = 0;
  std::array<double, 3> position_m{0, 0, 0};           // of B in W
  std::array<double, 4> orientation_xyzw{0, 0, 0, 1};  // rotation B -> W (Hamilton quaternion)
  bool tracked = false;  // false: held or propagated (lost, standing still, starting up)
  bool is_keyframe = false;
  /// The body's velocity [m/s] and angular velocity [rad/s] in its own frame B (a twist as
  /// nav_msgs/Odometry has it): the change from the previous pose of the same stream (the
  /// callback's or trajectory()'s) over the time between them; zero for the first pose and after
  /// a gap of more than a second.
  std::array<double, 3> velocity_body_mps{0, 0, 0};
  std::array<double, 3> angular_velocity_body_radps{0, 0, 0};
};

/// How the run is going (a ROS node's diagnostics, a robot's health monitor). Thread-safe to read
/// at any time; the figures are those of the latest frame processed.
struct Status {
  int frames_processed = 0;
  int frames_dropped = 0;  // realtime: images dropped because processing was behind
  /// Measurements not taken: not after the previous one of their kind, a non-finite value (gyro,
  /// accelerometer, a scan's angles or stamps), or after finish().
  int refused = 0;
  bool tracking = false;  // the latest frame's pose came from the camera
  std::string reason;     // why not, when not ("low_parallax", "too_few_matches", ...)
  int tracking_losses = 0;
  double frame_ms = 0.0;   // the latest frame's processing time (frontend and estimator), ms
  double solve_ms = 0.0;   // the latest keyframe's estimator time (the window's solve), ms
  int solve_failures = 0;  // window: solves whose states were restored (see ovo run's metrics)
  /// The camera-gyro offset in use, s (image stamp minus its time on the gyro clock): the rig's
  /// camera.time_offset_s plus, for the window, its own estimate on top.
  double time_offset_s = 0.0;
  bool time_offset_estimated = false;
  /// realtime: what stopped the processing threads (finish() rethrows it); empty while all is well.
  std::string error;
};

/// One IMU sample in the body frame: the gyro [rad/s] and, where the IMU has one, the
/// accelerometer.
struct GyroSample {
  std::int64_t t_ns = 0;
  double wx = 0, wy = 0, wz = 0;
  /// The IMU's accelerometer at the same time, specific force in the body frame, m/s^2 (the
  /// window's tilt reference, window.accel_sigma_mps2); all three 0: a gyro without one.
  double ax = 0, ay = 0, az = 0;
};

/// One planar LiDAR scan in the LiDAR frame (sensor_msgs/LaserScan): beam i at angle
/// angle_min + i * angle_increment in the x-y plane, measured at t_ns + i * time_increment; a
/// range outside [range_min, range_max] (or NaN/inf) is no return.
struct Scan {
  std::int64_t t_ns = 0;
  double angle_min_rad = 0, angle_increment_rad = 0;
  double range_min_m = 0, range_max_m = 0;
  double time_increment_s = 0;
  std::vector<float> ranges_m;
};

struct OdometryOptions {
  std::string estimator = "window";   // window (sliding window), kf (Kalman filter), vo (camera)
  std::string config_file;            // optional YAML of estimator keys (ovo's configs/)
  std::vector<std::string> settings;  // optional overrides "key.path=value"
  /// Compute preset, as `ovo run --budget`: "full" (the configuration as given) or "low" (a small
  /// robot computer: half-resolution frontend, 2 solver iterations; the README's "Speed" gives
  /// its cost in accuracy). Keys set by config_file or settings win.
  std::string budget = "full";
  bool use_gyro = true;   // false when the robot has no gyro
  bool use_lidar = true;  // false when it has no LiDAR
  /// false (offline): every measurement is processed in the calling thread, in time order, none
  /// dropped; an image waits for the first gyro sample at or after its time (or finish()). The
  /// poses are those of `ovo run`. true (live): two threads of their own process the images; when
  /// they fall behind the oldest waiting image is dropped; the callback runs on their thread.
  bool realtime = false;
  /// true: trajectory() gives every frame's final pose (memory grows with the run, about 170
  /// bytes a frame). false: only the recent past that the estimator may still change, so that
  /// memory stays flat over a working day; take the poses from the callback.
  bool keep_trajectory = true;
};

/// Visual odometry over a stream of measurements. Feed each sensor in time order.
class Odometry {
 public:
  using PoseCallback = std::function<void(const Pose&)>;

  /// rig_file: a rig.yaml (T_B_C, T_B_L, camera/gyro/lidar noise figures) whose
  /// camera.calibration key names the camera calibration (OCamCalib calib_results.txt or a
  /// sensor.yaml), else calib_results.txt or sensor.yaml beside it or in cam0/. on_pose is called
  /// once for every processed image. Errors (a bad rig file, calibration or configuration key)
  /// are std::runtime_error exceptions whose message names the file, the key and what was
  /// expected; so are an error in processing, thrown by the call that meets it (or finish()).
  Odometry(const std::string& rig_file, const OdometryOptions& options, PoseCallback on_pose);
  ~Odometry();
  Odometry(const Odometry&) = delete;
  Odometry& operator=(const Odometry&) = delete;

  /// Returns false (and ignores it, counted in status().refused) for a measurement not after the
  /// previous one of its kind, with a non-finite value, or after finish(). addImage throws for an
  /// image that is not 8-bit grey, BGR or BGRA, or not of the calibration's size.
  bool addImage(std::int64_t t_ns, const cv::Mat& image);
  bool addGyro(const GyroSample& sample);
  bool addScan(const Scan& scan);

  /// Processes everything still waiting and ends the run (a window estimator refines its last
  /// poses). Idempotent.
  void finish();
  /// The final pose of every processed frame (after finish(); before it, the poses so far).
  std::vector<Pose> trajectory() const;
  /// Images processed, and dropped (realtime only).
  int framesProcessed() const;
  int framesDropped() const;
  Status status() const;
  /// The rig's sensors in the body frame (from the rig file): the camera's pose T_B_C and the
  /// LiDAR's T_B_L, as Poses with t_ns 0 (a ROS node's static transforms).
  Pose cameraInBody() const;
  Pose lidarInBody() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace ovo
