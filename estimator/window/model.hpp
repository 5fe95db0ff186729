// The constants of the window's factors (noise, losses, bounds, what is estimated), made from the
// rig and the options, and the questions they answer (does the window estimate the time offset,
// the camera height, tie the vision's rotations to the gyro's).
#pragma once

#include "common/types.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// Constants of the window's factors.
struct WindowModel {
  SE3 T_B_C = SE3::Identity();             // (the LiDAR's pose is each keyframe's: Keyframe::T_B_L)
  double focal_px = 305.0;                 // the camera's focal length at the centre, px
  double pixel_sigma_px = 0.5;             // a sighting's noise, px
  double bearing_sigma_rad = 0.5 / 305.0;  // the same at the centre, rad (per-frame tracking)
  // Sightings' noise in the image: whitened by the camera's pixels per radian at each bearing
  // (TrackObservation::px_per_rad), else by focal_px alone.
  bool bearing_sigma_from_camera = true;
  double bearing_huber = 2.0;   // Huber threshold on the whitened residual (sigmas)
  double track_creep_px = 0.0;  // track creep per sqrt(frame) between anchor and observation, px
  bool bearing_steps = false;   // sightings after a track's first: BearingStepFactor from the
  double track_white_px = 0.0;  // previous one, whose sighting noise (px, each end) it carries
  double lidar_sigma_m = 0.02;  // a range to a landmark (range and association noise), m
  double lidar_range_sigma_m = 0.02;    // the LiDAR's range noise alone, m
  double lidar_ground_sigma_m = 0.002;  // the ground's own departure from a ground beam's plane, m
  double lidar_huber = 2.0;             // robust loss threshold on the whitened residual (sigmas)
  bool lidar_cauchy = false;         // Cauchy (an association far off pulls ever less), else Huber
  double bias_random_walk = 2.0e-5;  // rad/s^2/sqrt(Hz)
  // The accelerometer's tilt factors (factors::AccelerationFactor; 0: none), its bias prior, and
  // gravity's magnitude.
  double accel_sigma_mps2 = 0.0;
  double accel_position_sigma_m = 5e-4;
  double accel_bias_sigma_mps2 = 0.1;
  double gravity_mps2 = 9.81;
  double vision_rotation_sigma_rad = 0.0;  // a keyframe's orientation error as the vision sees
                                           // it (RotationTieFactor; 0: no tie, one orientation)
  double bias_prior_sigma_radps = 0.02;
  double gauge_sigma_position_m = 1e-4;
  double gauge_sigma_rotation_rad = 1e-4;
  double min_rho = 0.0;        // 1/m: points at infinity are kept (they hold the rotations)
  double max_rho = 1.0 / 0.1;  // 1/m: nearer landmarks are removed
  bool use_gyro = true;
  // A rolling shutter: image row v of image_rows is read out at the frame's time + v / rows *
  // this (s; 0: a global shutter, the rig's T_B_C for every sighting).
  double rolling_shutter_s = 0.0;
  double image_rows = 480.0;
  /// When the row of pixel px is exposed, s after the frame's time (TrackObservation::row_s).
  double rowTime(const Vec2& px) const;
  // The camera-gyro time offset on top of the rig's (WindowMap::time_offset_s): estimated with
  // this prior sigma about 0 when > 0 and there is a gyro, else held at its value.
  double time_offset_sigma_s = 0.0;
  double camera_height_m = 0.0;  // ground landmarks' depth below the camera, m (<= 0: no factor)
  // A correction of camera_height_m (WindowMap::camera_height_offset_m): estimated with this
  // prior sigma about 0 when > 0 (with a LiDAR to see it), else none.
  double camera_height_offset_sigma_m = 0.0;
  // The correction along the path instead (Keyframe::height_offset_m): its Gauss-Markov process's
  // standard deviation (m; 0: none) and correlation length (m) in the distance driven.
  double camera_height_path_sigma_m = 0.0;
  double camera_height_path_length_m = 3.0;
  double ground_sigma_m = 0.03;  // camera-height factor noise, m
  double ground_huber = 2.0;     // its Huber threshold, sigmas
  // Terrain planes (with a camera height): a ground landmark also lies on its anchor's terrain
  // plane (noise ground_sigma_m), which walks between keyframes by these per sqrt(m) driven.
  bool terrain_planes = false;
  double terrain_slope_walk = 0.002;   // slope (dz/dx, dz/dy) per sqrt(m)
  double terrain_height_walk = 0.002;  // m per sqrt(m)
};

/// The window's model from the rig and the options (an option < 0 takes the rig's figure).
WindowModel makeWindowModel(const SensorSetup& setup, const WindowOptions& options);

/// True when the model estimates a correction of the camera height (a height and a prior sigma).
inline bool estimatesCameraHeight(const WindowModel& model) {
  return model.camera_height_m > 0.0 && model.camera_height_offset_sigma_m > 0.0;
}

/// The camera height along the path's sigma when estimated (window.camera_height_path_sigma_m 0,
/// the terrain's roughness from the LiDAR's ground beams): at least this (smooth ground, where the
/// corrections are then held to a fraction of a millimetre; also before the LiDAR says more), at
/// most this, m.
constexpr double kPathHeightSigmaMinM = 1e-4;
constexpr double kPathHeightSigmaMaxM = 0.05;

/// True when each keyframe carries a correction of the camera height (Keyframe::height_offset_m).
inline bool followsCameraHeight(const WindowModel& model) {
  return model.camera_height_m > 0.0 && model.camera_height_path_sigma_m > 0.0;
}

/// True when the keyframes' accelerometer intervals give tilt factors (needs the gyro to turn the
/// samples).
inline bool usesAccel(const WindowModel& model) {
  return model.use_gyro && model.accel_sigma_mps2 > 0.0;
}

/// True when the model estimates the camera-gyro time offset (a gyro and a prior sigma).
inline bool estimatesTimeOffset(const WindowModel& model) {
  return model.use_gyro && model.time_offset_sigma_s > 0.0;
}

/// True when the keyframes' gyro factors see an orientation of their own (q_W_G), tied to q_W_B.
bool tiedRotations(const WindowModel& model);
}  // namespace ovo::estimator
