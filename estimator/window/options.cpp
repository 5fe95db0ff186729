// Reading the window's options from a configuration.
#include "estimator/window/options.hpp"

#include "common/error.hpp"

namespace ovo::estimator {

WindowOptions readWindowOptions(const Config& c) {
  WindowOptions o;
  const std::string p = "window.";
  o.use_gyro = c.get<bool>(p + "use_gyro", o.use_gyro);
  o.use_lidar = c.get<bool>(p + "use_lidar", o.use_lidar);

  o.window_size = c.getIntInRange(p + "window_size", o.window_size, 2, 100);
  o.kf_parallax_deg = c.getInRange(p + "kf_parallax_deg", o.kf_parallax_deg, 0.01, 45.0);
  o.kf_parallax_scan_fraction =
      c.getInRange(p + "kf_parallax_scan_fraction", o.kf_parallax_scan_fraction, 0.0, 1.0);
  o.kf_track_fraction = c.getInRange(p + "kf_track_fraction", o.kf_track_fraction, 0.0, 1.0);
  o.kf_track_fraction_between_scans = c.getInRange(p + "kf_track_fraction_between_scans",
                                                   o.kf_track_fraction_between_scans, 0.0, 1.0);
  o.kf_max_interval_s = c.getInRange(p + "kf_max_interval_s", o.kf_max_interval_s, 0.01, 1e3);
  o.min_landmark_observations =
      c.getIntInRange(p + "min_landmark_observations", o.min_landmark_observations, 3, 10000);
  o.min_inlier_fraction = c.getInRange(p + "min_inlier_fraction", o.min_inlier_fraction, 0.0, 1.0);

  o.max_features = c.getIntInRange(p + "max_features", o.max_features, 10, 100000);
  o.max_lidar_features = c.getIntInRange(p + "max_lidar_features", o.max_lidar_features, 0, 100000);
  o.feature_cell_px = c.getInRange(p + "feature_cell_px", o.feature_cell_px, 1.0, 1000.0);
  o.features_per_cell = c.getIntInRange(p + "features_per_cell", o.features_per_cell, 1, 1000);

  o.landmark_min_parallax_deg =
      c.getInRange(p + "landmark_min_parallax_deg", o.landmark_min_parallax_deg, 0.0, 45.0);
  o.landmark_min_depth_m =
      c.getInRange(p + "landmark_min_depth_m", o.landmark_min_depth_m, 1e-3, 1e3);
  o.landmark_max_depth_m =
      c.getInRange(p + "landmark_max_depth_m", o.landmark_max_depth_m, 0.1, 1e6);
  o.outlier_angle_deg = c.getInRange(p + "outlier_angle_deg", o.outlier_angle_deg, 1e-3, 45.0);
  o.outlier_sigmas = c.getInRange(p + "outlier_sigmas", o.outlier_sigmas, 0.5, 1e3);

  o.pixel_sigma = c.getInRange(p + "pixel_sigma", o.pixel_sigma, -1.0, 100.0);
  o.bearing_sigma_from_camera =
      c.get<bool>(p + "bearing_sigma_from_camera", o.bearing_sigma_from_camera);
  o.bearing_huber_sigmas =
      c.getInRange(p + "bearing_huber_sigmas", o.bearing_huber_sigmas, 0.1, 100.0);
  o.lidar_range_sigma_m =
      c.getInRange(p + "lidar_range_sigma_m", o.lidar_range_sigma_m, -1.0, 10.0);
  o.lidar_association_sigma_m =
      c.getInRange(p + "lidar_association_sigma_m", o.lidar_association_sigma_m, 0.0, 10.0);
  o.lidar_huber_sigmas = c.getInRange(p + "lidar_huber_sigmas", o.lidar_huber_sigmas, 0.1, 100.0);
  o.gyro_max_jump_radps = c.getInRange(p + "gyro_max_jump_radps", o.gyro_max_jump_radps, -1.0, 1e4);
  o.gyro_max_spike_s = c.getInRange(p + "gyro_max_spike_s", o.gyro_max_spike_s, 0.0, 10.0);
  o.gyro_bias_random_walk =
      c.getInRange(p + "gyro_bias_random_walk", o.gyro_bias_random_walk, -1.0, 1.0);
  o.vision_rotation_sigma_rad =
      c.getInRange(p + "vision_rotation_sigma_rad", o.vision_rotation_sigma_rad, 0.0, 1.0);
  o.accel_sigma_mps2 = c.getInRange(p + "accel_sigma_mps2", o.accel_sigma_mps2, 0.0, 100.0);
  o.accel_position_sigma_m =
      c.getInRange(p + "accel_position_sigma_m", o.accel_position_sigma_m, 0.0, 10.0);
  o.accel_bias_sigma_mps2 =
      c.getInRange(p + "accel_bias_sigma_mps2", o.accel_bias_sigma_mps2, 1e-6, 100.0);
  o.reinit_bias_sigma_radps =
      c.getInRange(p + "reinit_bias_sigma_radps", o.reinit_bias_sigma_radps, 1e-9, 10.0);
  o.gyro_bias_prior_sigma_radps =
      c.getInRange(p + "gyro_bias_prior_sigma_radps", o.gyro_bias_prior_sigma_radps, 1e-9, 10.0);
  o.estimate_time_offset = c.get<bool>(p + "estimate_time_offset", o.estimate_time_offset);
  o.rolling_shutter = c.get<bool>(p + "rolling_shutter", o.rolling_shutter);
  o.time_offset_sigma_s = c.getInRange(p + "time_offset_sigma_s", o.time_offset_sigma_s, 1e-6, 1.0);
  o.time_offset_max_s = c.getInRange(p + "time_offset_max_s", o.time_offset_max_s, 1e-4, 0.5);
  o.gauge_sigma_position_m =
      c.getInRange(p + "gauge_sigma_position_m", o.gauge_sigma_position_m, 1e-9, 1e3);
  o.gauge_sigma_yaw_rad =
      c.getInRange(p + "gauge_sigma_yaw_rad", o.gauge_sigma_yaw_rad, 1e-9, 10.0);
  o.rotation_prior_sigma_rad =
      c.getInRange(p + "rotation_prior_sigma_rad", o.rotation_prior_sigma_rad, 1e-9, 10.0);

  o.lidar_radius_px = c.getInRange(p + "lidar_radius_px", o.lidar_radius_px, 0.1, 100.0);
  o.lidar_depth_gate = c.getInRange(p + "lidar_depth_gate", o.lidar_depth_gate, 0.0, 10.0);
  o.lidar_edge_step = c.getInRange(p + "lidar_edge_step", o.lidar_edge_step, 0.0, 10.0);
  o.lidar_interpolate = c.get<bool>(p + "lidar_interpolate", o.lidar_interpolate);
  o.lidar_ground_sigma_m =
      c.getInRange(p + "lidar_ground_sigma_m", o.lidar_ground_sigma_m, 1e-4, 10.0);
  o.lidar_ground_beams = c.getEnum(
      p + "lidar_ground_beams", o.lidar_ground_beams,
      {{"plane", GroundBeams::kPlane}, {"skip", GroundBeams::kSkip}, {"raw", GroundBeams::kRaw}});
  o.lidar_max_elevation_deg =
      c.getInRange(p + "lidar_max_elevation_deg", o.lidar_max_elevation_deg, 0.0, 45.0);
  o.lidar_outlier_sigmas =
      c.getInRange(p + "lidar_outlier_sigmas", o.lidar_outlier_sigmas, 0.0, 1000.0);
  o.lidar_outlier_fraction =
      c.getInRange(p + "lidar_outlier_fraction", o.lidar_outlier_fraction, 0.0, 10.0);
  o.lidar_loss = c.getEnum(p + "lidar_loss", o.lidar_loss,
                           {{"huber", RobustLoss::kHuber}, {"cauchy", RobustLoss::kCauchy}});
  o.lidar_edge_neighbours =
      c.getIntInRange(p + "lidar_edge_neighbours", o.lidar_edge_neighbours, 0, 20);
  o.lidar_scan_time_tol_s =
      c.getInRange(p + "lidar_scan_time_tol_s", o.lidar_scan_time_tol_s, 0.0, 1.0);
  o.lidar_deskew = c.get<bool>(p + "lidar_deskew", o.lidar_deskew);
  o.lidar_scan_max_age_s =
      c.getInRange(p + "lidar_scan_max_age_s", o.lidar_scan_max_age_s, 0.0, 1.0);
  o.lidar_min_associations =
      c.getIntInRange(p + "lidar_min_associations", o.lidar_min_associations, 1, 10000);
  o.lidar_rescale_ratio = c.getInRange(p + "lidar_rescale_ratio", o.lidar_rescale_ratio, 0.0, 10.0);
  o.lidar_rescale_min_ranges =
      c.getIntInRange(p + "lidar_rescale_min_ranges", o.lidar_rescale_min_ranges, 3, 10000);
  o.lidar_rescale_agreement =
      c.getInRange(p + "lidar_rescale_agreement", o.lidar_rescale_agreement, 0.001, 1.0);

  o.init_parallax_deg = c.getInRange(p + "init_parallax_deg", o.init_parallax_deg, 0.01, 45.0);
  o.init_min_tracks = c.getIntInRange(p + "init_min_tracks", o.init_min_tracks, 8, 100000);
  o.init_max_wait_s = c.getInRange(p + "init_max_wait_s", o.init_max_wait_s, 0.05, 1e3);

  o.standstill_flow_px = c.getInRange(p + "standstill_flow_px", o.standstill_flow_px, 0.0, 100.0);
  o.standstill_gyro_radps =
      c.getInRange(p + "standstill_gyro_radps", o.standstill_gyro_radps, 0.0, 10.0);
  o.standstill_gyro_std_radps =
      c.getInRange(p + "standstill_gyro_std_radps", o.standstill_gyro_std_radps, 0.0, 10.0);
  o.standstill_min_bias_s =
      c.getInRange(p + "standstill_min_bias_s", o.standstill_min_bias_s, 0.0, 100.0);
  o.track_creep_px = c.getInRange(p + "track_creep_px", o.track_creep_px, 0.0, 100.0);
  o.bearing_steps = c.get<bool>(p + "bearing_steps", o.bearing_steps);
  o.track_white_px = c.getInRange(p + "track_white_px", o.track_white_px, 0.0, 100.0);
  o.standstill_trim_s = c.getInRange(p + "standstill_trim_s", o.standstill_trim_s, 0.0, 100.0);
  o.standstill_settle_s =
      c.getInRange(p + "standstill_settle_s", o.standstill_settle_s, 0.0, 100.0);

  o.velocity_decay_per_s =
      c.getInRange(p + "velocity_decay_per_s", o.velocity_decay_per_s, 0.0, 1.0);
  o.reinit_after_lost_frames =
      c.getIntInRange(p + "reinit_after_lost_frames", o.reinit_after_lost_frames, 1, 100000);

  o.linear_solver = c.getEnum(p + "linear_solver", o.linear_solver,
                              {{"landmark_schur", LinearSolver::kLandmarkSchur},
                               {"dense_schur", LinearSolver::kDenseSchur},
                               {"sparse_schur", LinearSolver::kSparseSchur}});
  o.max_iterations = c.getIntInRange(p + "max_iterations", o.max_iterations, 1, 1000);
  o.solver_stop_decrease =
      c.getInRange(p + "solver_stop_decrease", o.solver_stop_decrease, 0.0, 1.0);
  o.max_solver_time_s = c.getInRange(p + "max_solver_time_s", o.max_solver_time_s, 0.0, 100.0);
  o.motion_only_iterations =
      c.getIntInRange(p + "motion_only_iterations", o.motion_only_iterations, 1, 100);
  o.frame_rotation_from_gyro =
      c.get<bool>(p + "frame_rotation_from_gyro", o.frame_rotation_from_gyro);
  o.refine =
      c.getEnum(p + "refine", o.refine, {{"none", RefineMode::kNone}, {"full", RefineMode::kFull}});
  o.refine_iterations = c.getIntInRange(p + "refine_iterations", o.refine_iterations, 1, 1000);
  o.refine_passes = c.getIntInRange(p + "refine_passes", o.refine_passes, 1, 10);
  o.refine_bearing_steps = c.get<bool>(p + "refine_bearing_steps", o.refine_bearing_steps);
  o.refine_max_span_frames =
      c.getIntInRange(p + "refine_max_span_frames", o.refine_max_span_frames, 0, 1000000);
  o.refine_ground = c.get<bool>(p + "refine_ground", o.refine_ground);
  o.marginalize_max_landmarks =
      c.getIntInRange(p + "marginalize_max_landmarks", o.marginalize_max_landmarks, 0, 100000);
  o.use_ground_height = c.get<bool>(p + "use_ground_height", o.use_ground_height);
  o.ground_height_sigma_m =
      c.getInRange(p + "ground_height_sigma_m", o.ground_height_sigma_m, 1e-4, 10.0);
  o.estimate_camera_height = c.get<bool>(p + "estimate_camera_height", o.estimate_camera_height);
  o.camera_height_sigma_m =
      c.getInRange(p + "camera_height_sigma_m", o.camera_height_sigma_m, 1e-4, 1.0);
  o.camera_height_path = c.get<bool>(p + "camera_height_path", o.camera_height_path);
  o.camera_height_path_sigma_m =
      c.getInRange(p + "camera_height_path_sigma_m", o.camera_height_path_sigma_m, 0.0, 1.0);
  o.camera_height_path_length_m =
      c.getInRange(p + "camera_height_path_length_m", o.camera_height_path_length_m, 0.01, 1e4);
  if (o.camera_height_path_sigma_m > 0.0 && o.camera_height_path_sigma_m < 1e-4)
    fail("{}: {}camera_height_path_sigma_m: expected 0 (estimated) or at least 1e-4 m, got {}",
         c.location(p + "camera_height_path_sigma_m"), p, o.camera_height_path_sigma_m);
  if (o.camera_height_path && o.estimate_camera_height)
    fail(
        "{}: {}camera_height_path and {}estimate_camera_height are two models of the camera's "
        "height (along the path, or one for the run): set at most one of them to true",
        c.location(p + "camera_height_path"), p, p);
  o.ground_max_distance_heights =
      c.getInRange(p + "ground_max_distance_heights", o.ground_max_distance_heights, 0.1, 1000.0);
  o.ground_min_depression_deg =
      c.getInRange(p + "ground_min_depression_deg", o.ground_min_depression_deg, 0.0, 89.0);
  o.ground_scale_gate = c.getInRange(p + "ground_scale_gate", o.ground_scale_gate, 0.0, 1.0);
  o.ground_scale_gate_no_lidar =
      c.getInRange(p + "ground_scale_gate_no_lidar", o.ground_scale_gate_no_lidar, 0.0, 1.0);
  o.ground_normal_max_deg_no_lidar = c.getInRange(p + "ground_normal_max_deg_no_lidar",
                                                  o.ground_normal_max_deg_no_lidar, 0.0, 90.0);
  o.ground_inlier_fraction =
      c.getInRange(p + "ground_inlier_fraction", o.ground_inlier_fraction, 1e-4, 1.0);
  o.terrain_planes = c.get<bool>(p + "terrain_planes", o.terrain_planes);
  o.terrain_slope_walk = c.getInRange(p + "terrain_slope_walk", o.terrain_slope_walk, 1e-6, 10.0);
  o.terrain_height_walk =
      c.getInRange(p + "terrain_height_walk", o.terrain_height_walk, 1e-6, 10.0);
  o.marginalize_reanchored =
      c.getEnum(p + "marginalize_reanchored", o.marginalize_reanchored,
                {{"link", ReanchoredPrior::kLink}, {"none", ReanchoredPrior::kNone}});

  o.gyro = factors::readGyroPreintegrationOptions(c, "gyro");
  return o;
}

}  // namespace ovo::estimator
