// A simulator scenario: the vineyard, the robot's motion, the sensors and the nuisances, read from
// a YAML file (configs/sim/*.yaml) by readScenario(). Frames: world W is gravity-aligned with z up
// (gravity -z), rows run along +x and are stacked along +y; body B = IMU frame, x forward, y left,
// z up (ROS convention); camera C x right, y down, z forward; LiDAR L scans its x-y plane.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "common/types.hpp"

namespace ovo {
class Config;
}

namespace ovo::sim {

/// Vineyard geometry and appearance.
struct WorldOptions {
  int num_rows = 6;               // vine rows; row i runs along x at y = i * row_spacing_m
  double row_spacing_m = 2.5;     // between row centre lines
  double row_length_m = 40.0;     // rows span x in [0, row_length_m]
  double headland_m = 8.0;        // width of the headland track beyond both row ends
  double grade_pct = 0.0;         // terrain slope along the rows (+x uphill), percent
  double side_tilt_pct = 0.0;     // terrain slope across the rows (+y uphill), percent
  double canopy_bottom_m = 0.55;  // canopy height range above the ground
  double canopy_top_m = 1.9;
  double canopy_width_m = 0.5;    // thickness of the canopy slab across the row
  int canopy_layers = 3;          // see-through leaf layers across the slab
  double leaf_density = 0.6;      // fraction of a layer covered by leaves, in [0, 1]
  double leaf_size_m = 0.07;      // typical leaf-cluster size
  double plant_spacing_m = 1.1;   // vine spacing along the row
  double gap_probability = 0.12;  // chance that a vine is missing (a gap in the canopy)
  double trunk_radius_m = 0.04;
  double post_spacing_m = 5.5;  // trellis posts along the row
  double post_radius_m = 0.045;
  double post_height_m = 2.1;
  std::vector<double> wire_heights_m{0.55, 1.05, 1.45};  // trellis wires above the ground
  double wire_radius_m = 0.0015;
  double grass_width_m = 1.0;  // grass strip along the middle of each inter-row
  bool backdrop = true;        // distant wooded hills around the field
  double backdrop_distance_m = 150.0;
  double sun_azimuth_deg = 35.0;  // from +x towards +y
  double sun_elevation_deg = 45.0;
  // Uneven ground (0: the terrain is the exact plane of grade_pct and side_tilt_pct): a smooth
  // random height field (sum of random-phase waves, height std ground_roughness_m, wavelengths
  // around ground_wavelength_m) added vertically to the plane over the field and its headlands.
  // The robot drives on it (height, roll and pitch from the local normal); the rows stand on it.
  double ground_roughness_m = 0.0;
  double ground_wavelength_m = 2.0;
  // Wind (0: still): leaf clusters and shoots sway in the canopy plane by at most
  // wind_amplitude_m, smoothly, with periods around wind_period_s; trunks, posts, wires stay put.
  double wind_amplitude_m = 0.0;
  double wind_period_s = 2.0;
};

/// The robot's motion plan. The body origin moves on the terrain at body_height_m.
struct TrajectoryOptions {
  std::string kind = "rows";         // rows: passes joined by headland U-turns; spin: in-place turn
  double start_hold_s = 1.0;         // standing still before moving
  double end_hold_s = 1.0;           // standing still at the end
  double body_height_m = 0.3;        // body origin above the ground
  int first_interrow = 2;            // start between rows first_interrow and first_interrow + 1
  int passes = 2;                    // inter-row passes (kind rows)
  double first_pass_m = 12.0;        // length of the first pass, ending in the headland
  double last_pass_m = 12.0;         // length of the last pass (middle passes run the full row)
  double headland_entry_m = 1.5;     // how far past the row ends the robot drives before turning
  double speed_mps = 0.8;            // cruise speed in the rows
  double uturn_radius_m = 1.25;      // radius of the U-turn's quarter arcs; 0 = pivot turns
  double uturn_yaw_rate_dps = 20.0;  // yaw rate on the arcs (and of pivot turns)
  double uturn_speed_mps = 0.4;      // speed on the straight between the arcs
  bool turn_left = true;             // direction of the first U-turn
  double ramp_s = 1.0;               // smoothing of speed / yaw-rate changes (raised-cosine width)
  double stop_every_m = 0.0;         // stops while driving along rows (0: none)
  double stop_duration_s = 3.0;
  double spin_deg = 360.0;  // kind spin: in-place rotation angle (positive = left)
  double spin_rate_dps = 30.0;
  double lead_in_m = 3.0;  // kind spin: drive before and after the spin
  double lead_out_m = 3.0;
  double start_x_m = -1.0;           // kind spin: start position along the row (negative: auto)
  double bump_sigma_m = 0.004;       // vertical bumps at cruise speed (std)
  double vibration_sigma_deg = 0.3;  // roll / pitch vibration at cruise speed (std)
  double vibration_knot_s = 0.05;    // spline knot spacing (vibration bandwidth ~ 1 / (4 knots))
  double jitter = 1.0;               // scale of the seed's speed / heading / offset perturbations
};

/// Rigid mount of a sensor on the body: translation in B and angles from the nominal orientation.
struct MountOptions {
  double x_m = 0.0, y_m = 0.0, z_m = 0.0;
  double yaw_deg = 0.0;         // left positive, about body z
  double pitch_down_deg = 0.0;  // nose down positive
  double roll_deg = 0.0;        // about the sensor's forward axis
};

/// The camera and its mount. Nominal orientation: z_C = x_B, x_C = -y_B, y_C = -z_B.
struct CameraOptions {
  std::string model = "ocam";         // ocam | pinhole
  std::filesystem::path calibration;  // model ocam: a file camera::loadCamera reads
  int pinhole_width = 640;  // model pinhole: an ideal pinhole of this size and field of view
  int pinhole_height = 480;
  double pinhole_hfov_deg = 90.0;
  double rate_hz = 20.0;
  double pixel_sigma = 0.5;  // written to rig.yaml for estimators (pixels)
  MountOptions mount{0.35, 0.0, 0.7, 0.0, 12.0, 0.0};
  // Sensor realities, each off by default:
  double time_offset_s = 0.0;           // image stamp = true (gyro-clock) time + this
  double rolling_shutter_s = 0.0;       // rows read out top to bottom over this time (0: global)
  double frame_drop_probability = 0.0;  // chance that a frame is missing from the dataset
  bool auto_exposure = false;           // steps the gain when the view brightens or darkens
  double auto_exposure_step = 0.1;      // relative gain change of one step
  double auto_exposure_rate_hz = 2.0;   // at most this many steps a second
};

/// Ray-caster settings.
struct RenderOptions {
  int supersample = 1;           // k x k samples per pixel on top of the analytic filtering
  double footprint_scale = 1.0;  // filter width in pixels (1 = box filter of one pixel)
};

/// Image nuisances, each switchable.
struct NuisanceOptions {
  bool exposure_changes = true;
  double exposure_amplitude = 0.2;  // relative gain excursion (smooth random, +-)
  double exposure_period_s = 6.0;   // typical time scale of the gain changes
  bool image_noise = true;
  double noise_sigma = 1.5;  // grey levels, additive Gaussian (plus shot noise below)
  double shot_noise = 0.05;  // grey-level variance per grey level (photon noise)
  bool motion_blur = false;
  double exposure_time_s = 0.008;  // shutter time for motion blur
  int blur_samples = 4;            // sub-frames averaged over the shutter time
  int people = 0;                  // people walking through the camera's view
};

/// Gyroscope and accelerometer (B = IMU frame). Defaults: MEMS-grade (InvenSense MPU-9250 data
/// sheet: gyro rate noise density 0.01 deg/s/sqrt(Hz) = 1.7e-4 rad/s/sqrt(Hz), accelerometer
/// 300 ug/sqrt(Hz) = 2.9e-3 m/s^2/sqrt(Hz); bias random walk as commonly used for MPU/BMI-class
/// devices in VIO configs, e.g. OpenVINS / Kalibr IMU noise models).
struct ImuOptions {
  double rate_hz = 200.0;
  double gyro_noise_density = 1.7e-4;      // rad/s/sqrt(Hz)
  double gyro_bias_random_walk = 2.0e-5;   // rad/s^2/sqrt(Hz)
  double gyro_initial_bias_dps = 0.3;      // std of the initial bias per axis, deg/s
  double accel_noise_density = 2.9e-3;     // m/s^2/sqrt(Hz)
  double accel_bias_random_walk = 3.0e-4;  // m/s^3/sqrt(Hz)
  double accel_initial_bias = 0.05;        // std of the initial bias per axis, m/s^2
  bool noise = true;                       // false: exact rates and specific force, zero bias
  double time_jitter_s = 0.0;  // std of the stamps' jitter (samples still at the true times)
};

/// Planar LiDAR. Scans are stamped on the true time of every (camera rate / rate_hz)-th camera
/// frame (so LiDAR and camera stamps coincide when the camera has no time offset). Instantaneous
/// unless `sweep`: then beam i is taken at the stamp + i * scan_time_s * angle_increment / 360 deg
/// (a mirror turning once per scan_time_s, as ROS LaserScan's time_increment and scan_time).
struct LidarOptions {
  double rate_hz = 10.0;  // must divide the camera rate
  double angle_min_deg = -135.0;
  double angle_max_deg = 135.0;
  double angle_increment_deg = 0.5;
  double range_min_m = 0.1;
  double range_max_m = 12.0;
  double range_sigma_m = 0.02;        // Gaussian range noise
  double dropout_probability = 0.02;  // a beam returns nothing
  bool noise = true;                  // false: exact ranges, no dropouts
  MountOptions mount{0.45, 0.0, 0.45, 0.0, 8.0, 0.0};
  bool sweep = false;        // beams taken one after the other over the mirror's turn
  double scan_time_s = 0.0;  // one turn of the mirror (s); 0 = one scan period, 1 / rate_hz
  /// Time between beams (s): 0 unless sweep.
  double timeIncrementS() const {
    if (!sweep) return 0.0;
    const double turn = scan_time_s > 0.0 ? scan_time_s : 1.0 / rate_hz;
    return turn * angle_increment_deg / 360.0;
  }
};

/// What the simulator writes into the dataset's rig.yaml besides the truth: the values an
/// estimator starts from (a user's guess, not the simulator's truth).
struct RigOptions {
  double camera_time_offset_s = 0.0;  // rig.yaml camera.time_offset_s (the estimator's prior)
};

/// Everything one simulated sequence needs.
struct Scenario {
  std::string name;
  std::uint64_t seed = 1;
  double duration_s = 0.0;  // 0: the motion plan's length; otherwise cut (or held) to it
  int frames = 0;           // > 0: number of camera frames (wins over duration_s)
  Timestamp start_time_ns = 1'000'000'000;
  WorldOptions world;
  TrajectoryOptions trajectory;
  CameraOptions camera;
  RenderOptions render;
  NuisanceOptions nuisance;
  ImuOptions imu;
  LidarOptions lidar;
  RigOptions rig;
};

/// Reads a scenario; every key is optional (defaults above) and unknown keys are errors
/// (checkAllUsed). camera.calibration is resolved against the current folder, then the config
/// file's folder and its parents. Throws ovo::Error naming the key and what was expected.
Scenario readScenario(const Config& config);

/// The scenario as YAML in the layout readScenario() reads (written to sim/scenario.yaml).
std::string scenarioYaml(const Scenario& scenario);

/// T_B_S of a mount: nominal sensor axes (`R_B_S0`) turned by yaw, pitch-down and roll.
SE3 mountTransform(const MountOptions& mount, const Mat3& R_B_S0);
/// Camera: z_C = x_B, x_C = -y_B, y_C = -z_B before the mount angles.
SE3 cameraMountTransform(const MountOptions& mount);
/// LiDAR: L = B before the mount angles.
SE3 lidarMountTransform(const MountOptions& mount);

}  // namespace ovo::sim
