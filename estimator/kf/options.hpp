// The kf baseline's options: its keys under "kf." (configs/estimator/kf.yaml) and the `vo`
// chain's camera height, speed limit and ground plane under "vo.", read from a configuration.
#pragma once

#include "common/config.hpp"
#include "estimator/common/ground_plane.hpp"
#include "estimator/common/gyro_front.hpp"
#include "estimator/common/lidar_scale.hpp"
#include "estimator/estimator.hpp"
#include "estimator/kf/filter.hpp"

namespace ovo::estimator {

/// Tuning of the kf estimator: keys under "kf." (configs/estimator/kf.yaml), and the `vo` chain's
/// camera height, speed limit and ground plane under "vo.".
struct KfEstimatorOptions {
  double camera_height_m = 0.0;         // above the ground; 0 = the rig's (fallback scale)
  double max_speed_mps = 40.0;          // scales implying more are rejected
  double lidar_scale_hold_s = 1.0;      // a LiDAR scale counts for frames this long after it, s
  double scan_time_tolerance_s = 0.01;  // a scan belongs to a frame within this time, s
  double lidar_baseline_s = 0.6;        // tracks are checked against the LiDAR over this span, s
  double lidar_min_baseline_m = 0.1;    // shorter spans (turning in place, stops) are skipped, m
  double lidar_max_rotation_deg = 5.0;  // ... and spans that turn more about the world's up
                                        // (their translation is the chain's weakest, and the
                                        // scale follows it; pitch and roll over bumps do not
                                        // count), deg
  double scale_sigma0 = 0.3;            // prior on log(LiDAR/ground-plane scale) (camera height), 1
  double scale_walk = 0.002;            // its random walk, 1/sqrt(s)
  double scale_noise_floor = 0.05;      // smallest noise of one LiDAR measurement of it, 1
  double scale_gate_chi2 = 16.0;        // LiDAR measurements with a larger innovation are dropped
  double scale_deadband = 0.02;         // c is applied once |log c| exceeds this and 3 sigma, 1
  bool refit_translation = false;       // true: translation direction re-fit to the fused rotation
                                   // (measured worse than the RANSAC direction on the simulator)
  bool zero_rate_update = true;  // standstill: the mean gyro rate measures the bias (ZARU)
  double still_flow_deg = 0.15;  // standstill: median angle between the bearings of the reference
                                 // and the current image below this, deg (tracked positions wander
                                 // a little with exposure changes even when still)
  double still_gyro_std_radps = 0.005;  // ... and the frame's gyro samples this quiet, rad/s
                                        // (2x the sample noise of a MEMS gyro at 200 Hz; ride
                                        // vibration at cruise speed gives 0.004-0.01)
  double still_trim_s = 0.3;  // a still frame's zero-rate update waits until the standstill has
                              // lasted this long after it, and is dropped if the motion starts
                              // first (the first moving frames look still: one of them can put
                              // its slow turn into the bias, where it stays), s
  bool use_gyro = true;
  double gyro_max_jump_radps = 10.0;  // a gyro sample whose rate jumps more than this from the
                                      // last one used, on any axis, is a spike and unused, by the
                                      // filter and the matching prior alike (<= 0: all used) ...
  double gyro_max_spike_s = 0.05;     // ... for at most this long (a jump that lasts is real), s
  bool use_lidar = true;
  bool lidar_deskew = true;  // a swept scan (per-beam times) is made instantaneous at its stamp
                             // before use: each beam turned back by the gyro's mean rate over
                             // the sweep (estimator/common/lidar_deskew.hpp; no translation)
  GroundPlaneOptions ground;
  LidarScaleOptions lidar;
  KfOptions filter;
  bool operator==(const KfEstimatorOptions&) const = default;
};

/// The options from cfg; the filter's gyro noise figures are the rig's (setup) unless cfg sets
/// them.
KfEstimatorOptions readKfEstimatorOptions(const Config& cfg, const SensorSetup& setup);

/// The kf's gyro front (the filter's and the frontend's matching prior's): its spike filter (the
/// kf integrates the samples itself, so the preintegration options are the defaults).
inline GyroFrontOptions gyroFrontOptions(const KfEstimatorOptions& options) {
  GyroFrontOptions o;
  o.max_jump_radps = options.gyro_max_jump_radps;
  o.max_spike_s = options.gyro_max_spike_s;
  return o;
}

}  // namespace ovo::estimator
