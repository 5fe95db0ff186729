// Reading the kf's options from a configuration.
#include "estimator/kf/options.hpp"

#include <algorithm>

namespace ovo::estimator {

KfEstimatorOptions readKfEstimatorOptions(const Config& cfg, const SensorSetup& setup) {
  KfEstimatorOptions o;
  o.camera_height_m = cfg.getInRange("vo.camera_height_m", o.camera_height_m, 0.0, 100.0);
  o.max_speed_mps = cfg.getInRange("vo.max_speed_mps", o.max_speed_mps, 0.01, 100.0);
  o.lidar_scale_hold_s = cfg.getInRange("kf.lidar_scale_hold_s", o.lidar_scale_hold_s, 0.0, 100.0);
  o.scan_time_tolerance_s =
      cfg.getInRange("kf.scan_time_tolerance_s", o.scan_time_tolerance_s, 0.0, 1.0);
  o.lidar_baseline_s = cfg.getInRange("kf.lidar_baseline_s", o.lidar_baseline_s, 0.01, 10.0);
  o.lidar_min_baseline_m =
      cfg.getInRange("kf.lidar_min_baseline_m", o.lidar_min_baseline_m, 0.0, 100.0);
  o.lidar_max_rotation_deg =
      cfg.getInRange("kf.lidar_max_rotation_deg", o.lidar_max_rotation_deg, 0.0, 180.0);
  o.scale_sigma0 = cfg.getInRange("kf.scale_sigma0", o.scale_sigma0, 1e-6, 10.0);
  o.scale_walk = cfg.getInRange("kf.scale_walk", o.scale_walk, 0.0, 10.0);
  o.scale_noise_floor = cfg.getInRange("kf.scale_noise_floor", o.scale_noise_floor, 1e-6, 10.0);
  o.scale_gate_chi2 = cfg.getInRange("kf.scale_gate_chi2", o.scale_gate_chi2, 0.0, 1e9);
  o.scale_deadband = cfg.getInRange("kf.scale_deadband", o.scale_deadband, 0.0, 1.0);
  o.refit_translation = cfg.get<bool>("kf.refit_translation", o.refit_translation);
  o.zero_rate_update = cfg.get<bool>("kf.zero_rate_update", o.zero_rate_update);
  o.still_flow_deg = cfg.getInRange("kf.still_flow_deg", o.still_flow_deg, 0.0, 10.0);
  o.still_gyro_std_radps =
      cfg.getInRange("kf.still_gyro_std_radps", o.still_gyro_std_radps, 0.0, 10.0);
  o.still_trim_s = cfg.getInRange("kf.still_trim_s", o.still_trim_s, 0.0, 10.0);
  o.use_gyro = cfg.get<bool>("kf.use_gyro", o.use_gyro);
  o.gyro_max_jump_radps =
      cfg.getInRange("kf.gyro_max_jump_radps", o.gyro_max_jump_radps, -1.0, 1e4);
  o.gyro_max_spike_s = cfg.getInRange("kf.gyro_max_spike_s", o.gyro_max_spike_s, 0.0, 10.0);
  o.use_lidar = cfg.get<bool>("kf.use_lidar", o.use_lidar);
  o.lidar_deskew = cfg.get<bool>("kf.lidar_deskew", o.lidar_deskew);
  o.ground = readGroundPlaneOptions(cfg);
  o.lidar = readLidarScaleOptions(cfg);
  // The filter's gyro noise defaults to the rig's figures unless the config sets them (read from
  // cfg itself so that every key counts as used).
  const bool has_noise = cfg.has("kf.gyro_noise_density");
  const bool has_walk = cfg.has("kf.gyro_bias_random_walk");
  o.filter = readKfOptions(cfg);
  if (!has_noise) o.filter.gyro_noise_density = std::max(setup.gyro_noise_density, 1e-9);
  if (!has_walk) o.filter.gyro_bias_random_walk = std::max(setup.gyro_bias_random_walk, 0.0);
  return o;
}

}  // namespace ovo::estimator
