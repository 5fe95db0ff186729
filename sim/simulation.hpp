// One simulated sequence: the scenario's world, trajectory, camera, rig and sensor models, and the
// calls that produce its frames, IMU samples, LiDAR scans and ground truth (the `ovo simulate`
// command writes them out). Deterministic for a seed: every random draw comes from a stream
// derived from the scenario seed and the sample's index, so frames may be rendered in any order.
// Times: frameTime(k) is frame k's true time on the gyro clock (its first row's exposure);
// frameStamp(k) is what the camera stamps it, offset by camera.time_offset_s.
#pragma once

#include <memory>
#include <opencv2/core.hpp>
#include <optional>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"
#include "sim/imu.hpp"
#include "sim/renderer.hpp"
#include "sim/scenario.hpp"
#include "sim/trajectory.hpp"
#include "sim/world.hpp"

namespace ovo::sim {

/// The scenario's camera: camera::loadCamera(calibration) or an ideal pinhole of the given field of
/// view. Throws ovo::Error when the calibration file is unusable.
camera::Camera makeCamera(const CameraOptions& options);

class Simulation {
 public:
  /// Builds everything except images; throws ovo::Error for an unusable camera file.
  explicit Simulation(const Scenario& scenario);
  /// With a given camera (tests, benchmarks).
  Simulation(const Scenario& scenario, const camera::Camera& camera);

  const Scenario& scenario() const { return scenario_; }
  const VineyardWorld& world() const { return *world_; }
  VineyardWorld& world() { return *world_; }
  const BodyTrajectory& trajectory() const { return trajectory_; }
  const camera::Camera& camera() const { return camera_; }
  const Renderer& renderer() const { return *renderer_; }
  const SE3& T_B_C() const { return T_B_C_; }
  const SE3& T_B_L() const { return T_B_L_; }

  /// Camera frames: k = 0 .. frameCount() - 1 at frameTime(k) seconds from the start.
  int frameCount() const { return frames_; }
  double frameTime(int k) const;
  /// Frame k's true time on the gyro clock (ns).
  Timestamp frameTrueStamp(int k) const { return scenario_.start_time_ns + frameOffsetNs(k); }
  /// Frame k's image stamp: the true time plus camera.time_offset_s.
  Timestamp frameStamp(int k) const { return frameTrueStamp(k) + time_offset_ns_; }
  /// Time (s from the start) at which row v of frame k is read out: frameTime(k) plus v / rows of
  /// camera.rolling_shutter_s.
  double rowTime(int k, int v) const;
  /// True when frame k is missing from the dataset (camera.frame_drop_probability).
  bool frameDropped(int k) const;
  /// Length of the sequence (s): the last frame's time.
  double duration() const { return frameTime(std::max(0, frames_ - 1)); }

  /// Frame k as 8-bit grey with exposure, noise, blur and people as the scenario says.
  cv::Mat renderFrame(int k) const;
  /// Relative exposure gain at time t (1 when exposure changes are off): the light changing.
  double exposureGain(double t_s) const;
  /// The auto-exposure's gain of frame k (1 when camera.auto_exposure is off): steps of
  /// camera.auto_exposure_step against the metered brightness of the frames before it.
  double autoExposureGain(int k) const;

  std::vector<ImuSample> imu(std::vector<GyroBiasSample>* true_gyro_bias = nullptr) const;
  /// Scans on every (camera rate / LiDAR rate)-th frame, stamped at those frames' true times (the
  /// first beam's, when swept).
  std::vector<LidarScan> lidar() const;
  /// T_W_B at every camera frame's true time and, when the camera's stamps are offset, at every
  /// image stamp too (read as a gyro-clock time): an estimate at either time finds its truth.
  ovo::Trajectory groundTruth() const;
  /// Camera centre's height above the terrain at the start (m).
  double cameraHeightM() const;
  /// Where the camera-frame ray d_C of a camera at T_W_C meets the first opaque surface at time
  /// t_s (VineyardWorld::firstOpaqueHit); nullopt when nothing is nearer than max_range_m.
  std::optional<Vec3> castRay(const SE3& T_W_C, const Vec3& d_C, double t_s,
                              double max_range_m) const;
  /// The same for the ray through pixel px; nullopt too when px is off the camera model.
  std::optional<Vec3> castPixel(const SE3& T_W_C, const Vec2& px, double t_s,
                                double max_range_m) const;

 private:
  void build();
  void computeAutoExposure();
  Timestamp frameOffsetNs(int k) const;

  Scenario scenario_;
  camera::Camera camera_;
  std::unique_ptr<VineyardWorld> world_;
  std::unique_ptr<Renderer> renderer_;
  BodyTrajectory trajectory_;
  SE3 T_B_C_, T_B_L_;
  int frames_ = 0;
  double gain_phase_[3] = {0.0, 0.0, 0.0};
  Timestamp time_offset_ns_ = 0;
  std::vector<double> auto_exposure_;  // per frame; empty when off
};

}  // namespace ovo::sim
