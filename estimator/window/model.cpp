// The window's model constants from the rig and the options.
#include "estimator/window/model.hpp"

#include <algorithm>
#include <cmath>

#include "camera/camera.hpp"

namespace ovo::estimator {

bool tiedRotations(const WindowModel& model) {
  return model.use_gyro && model.vision_rotation_sigma_rad > 0.0;
}

double WindowModel::rowTime(const Vec2& px) const {
  if (!(rolling_shutter_s > 0.0) || !(image_rows > 0.0)) return 0.0;
  return rolling_shutter_s * std::clamp(px.y() / image_rows, 0.0, 1.0);
}

WindowModel makeWindowModel(const SensorSetup& setup, const WindowOptions& options) {
  WindowModel model;
  const double pixel_sigma = options.pixel_sigma > 0.0 ? options.pixel_sigma : setup.pixel_sigma;
  model.T_B_C = setup.T_B_C;
  model.rolling_shutter_s = options.rolling_shutter ? setup.rolling_shutter_s : 0.0;
  model.image_rows = camera::height(setup.camera);
  model.focal_px = camera::focalPx(setup.camera);
  model.pixel_sigma_px = pixel_sigma;
  model.bearing_sigma_rad = pixel_sigma / model.focal_px;
  model.bearing_sigma_from_camera = options.bearing_sigma_from_camera;
  model.bearing_huber = options.bearing_huber_sigmas;
  model.track_creep_px = options.track_creep_px;
  model.bearing_steps = useBearingSteps(options.bearing_steps, options);
  model.track_white_px = options.track_white_px;
  model.lidar_ground_sigma_m = options.lidar_ground_sigma_m;
  model.lidar_range_sigma_m =
      options.lidar_range_sigma_m > 0.0 ? options.lidar_range_sigma_m : setup.lidar_range_sigma_m;
  model.lidar_sigma_m = std::hypot(model.lidar_range_sigma_m, options.lidar_association_sigma_m);
  model.lidar_huber = options.lidar_huber_sigmas;
  model.lidar_cauchy = options.lidar_loss == RobustLoss::kCauchy;
  model.bias_random_walk = options.gyro_bias_random_walk > 0.0 ? options.gyro_bias_random_walk
                                                               : setup.gyro_bias_random_walk;
  model.bias_prior_sigma_radps = options.gyro_bias_prior_sigma_radps;
  model.vision_rotation_sigma_rad = options.vision_rotation_sigma_rad;
  model.accel_sigma_mps2 = options.accel_sigma_mps2;
  model.accel_position_sigma_m = options.accel_position_sigma_m;
  model.accel_bias_sigma_mps2 = options.accel_bias_sigma_mps2;
  model.gauge_sigma_position_m = options.gauge_sigma_position_m;
  model.gauge_sigma_rotation_rad = options.gauge_sigma_yaw_rad;
  model.max_rho = 1.0 / (0.5 * options.landmark_min_depth_m);
  model.use_gyro = options.use_gyro && setup.has_gyro;
  model.time_offset_sigma_s = options.estimate_time_offset ? options.time_offset_sigma_s : 0.0;
  if (options.use_ground_height && setup.camera_height_m && *setup.camera_height_m > 0.0) {
    model.camera_height_m = *setup.camera_height_m;
    model.ground_sigma_m = options.ground_height_sigma_m;
    if (options.estimate_camera_height && options.use_lidar && setup.has_lidar)
      model.camera_height_offset_sigma_m = options.camera_height_sigma_m;
    if (options.camera_height_path && options.use_lidar && setup.has_lidar) {
      model.camera_height_path_sigma_m = options.camera_height_path_sigma_m > 0.0
                                             ? options.camera_height_path_sigma_m
                                             : kPathHeightSigmaMinM;  // then estimated
      model.camera_height_path_length_m = options.camera_height_path_length_m;
    }
    model.terrain_planes = options.terrain_planes;
    model.terrain_slope_walk = options.terrain_slope_walk;
    model.terrain_height_walk = options.terrain_height_walk;
  }
  return model;
}

}  // namespace ovo::estimator
