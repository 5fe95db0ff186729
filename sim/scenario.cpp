#include "sim/scenario.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>
#include <limits>

#include "common/config.hpp"
#include "common/error.hpp"

namespace ovo::sim {
namespace {

constexpr double kDeg = M_PI / 180.0;

MountOptions readMount(const Config& c, const std::string& p, const MountOptions& d) {
  MountOptions m;
  m.x_m = c.getInRange(p + ".x_m", d.x_m, -10.0, 10.0);
  m.y_m = c.getInRange(p + ".y_m", d.y_m, -10.0, 10.0);
  m.z_m = c.getInRange(p + ".z_m", d.z_m, -10.0, 10.0);
  m.yaw_deg = c.getInRange(p + ".yaw_deg", d.yaw_deg, -360.0, 360.0);
  m.pitch_down_deg = c.getInRange(p + ".pitch_down_deg", d.pitch_down_deg, -90.0, 90.0);
  m.roll_deg = c.getInRange(p + ".roll_deg", d.roll_deg, -180.0, 180.0);
  return m;
}

// Absolute path of a file named in the config: as given, from the current folder, or from the
// config file's folder and its parents (so "configs/cameras/x.txt" works from anywhere).
std::filesystem::path resolveFile(const Config& c, const std::string& key,
                                  const std::string& value) {
  namespace fs = std::filesystem;
  const fs::path p(value);
  if (p.is_absolute()) {
    if (fs::exists(p)) return p;
  } else {
    if (fs::exists(p)) return fs::absolute(p);
    fs::path dir = fs::absolute(fs::path(c.source())).parent_path();
    for (int i = 0; i < 8 && !dir.empty(); ++i) {
      if (fs::exists(dir / p)) return fs::weakly_canonical(dir / p);
      if (dir == dir.parent_path()) break;
      dir = dir.parent_path();
    }
  }
  fail("{}: key '{}': file '{}' not found (looked in the current folder and beside {})",
       c.location(key), key, value, c.source());
}

Mat3 rotZ(double a) { return Eigen::AngleAxisd(a, Vec3::UnitZ()).toRotationMatrix(); }
Mat3 rotY(double a) { return Eigen::AngleAxisd(a, Vec3::UnitY()).toRotationMatrix(); }
Mat3 rotX(double a) { return Eigen::AngleAxisd(a, Vec3::UnitX()).toRotationMatrix(); }

}  // namespace

SE3 mountTransform(const MountOptions& m, const Mat3& R_B_S0) {
  SE3 T = SE3::Identity();
  T.linear() =
      rotZ(m.yaw_deg * kDeg) * rotY(m.pitch_down_deg * kDeg) * rotX(m.roll_deg * kDeg) * R_B_S0;
  T.translation() = Vec3(m.x_m, m.y_m, m.z_m);
  return T;
}

SE3 cameraMountTransform(const MountOptions& mount) {
  Mat3 R_B_C0;
  R_B_C0.col(0) = -Vec3::UnitY();  // x_C = -y_B
  R_B_C0.col(1) = -Vec3::UnitZ();  // y_C = -z_B
  R_B_C0.col(2) = Vec3::UnitX();   // z_C = x_B
  return mountTransform(mount, R_B_C0);
}

SE3 lidarMountTransform(const MountOptions& mount) {
  return mountTransform(mount, Mat3::Identity());
}

Scenario readScenario(const Config& c) {
  Scenario s;
  s.name = c.get<std::string>("name", std::filesystem::path(c.source()).stem().string());
  s.seed = static_cast<std::uint64_t>(
      c.getInt64InRange("seed", 1, 0, std::numeric_limits<std::int64_t>::max()));
  s.duration_s = c.getInRange("duration_s", 0.0, 0.0, 3600.0);
  s.frames = c.getIntInRange("frames", 0, 0, 1'000'000);
  // At most 4e18 ns (the year 2096): a sequence's stamps must not overflow 2^63.
  s.start_time_ns =
      c.getInt64InRange("start_time_ns", s.start_time_ns, 0, 4'000'000'000'000'000'000LL);

  WorldOptions& w = s.world;
  const WorldOptions dw;
  w.num_rows = c.getIntInRange("world.num_rows", dw.num_rows, 0, 200);
  w.row_spacing_m = c.getInRange("world.row_spacing_m", dw.row_spacing_m, 1.0, 10.0);
  w.row_length_m = c.getInRange("world.row_length_m", dw.row_length_m, 1.0, 1000.0);
  w.headland_m = c.getInRange("world.headland_m", dw.headland_m, 0.0, 100.0);
  w.grade_pct = c.getInRange("world.grade_pct", dw.grade_pct, -60.0, 60.0);
  w.side_tilt_pct = c.getInRange("world.side_tilt_pct", dw.side_tilt_pct, -60.0, 60.0);
  w.canopy_bottom_m = c.getInRange("world.canopy_bottom_m", dw.canopy_bottom_m, 0.0, 5.0);
  w.canopy_top_m = c.getInRange("world.canopy_top_m", dw.canopy_top_m, 0.1, 6.0);
  if (w.canopy_top_m <= w.canopy_bottom_m + 0.1)
    fail("{}: world.canopy_top_m must exceed world.canopy_bottom_m by 0.1 m",
         c.location("world.canopy_top_m"));
  w.canopy_width_m = c.getInRange("world.canopy_width_m", dw.canopy_width_m, 0.05, 2.0);
  w.canopy_layers = c.getIntInRange("world.canopy_layers", dw.canopy_layers, 1, 6);
  w.leaf_density = c.getInRange("world.leaf_density", dw.leaf_density, 0.0, 1.0);
  w.leaf_size_m = c.getInRange("world.leaf_size_m", dw.leaf_size_m, 0.01, 1.0);
  w.plant_spacing_m = c.getInRange("world.plant_spacing_m", dw.plant_spacing_m, 0.3, 5.0);
  w.gap_probability = c.getInRange("world.gap_probability", dw.gap_probability, 0.0, 1.0);
  w.trunk_radius_m = c.getInRange("world.trunk_radius_m", dw.trunk_radius_m, 0.005, 0.3);
  w.post_spacing_m = c.getInRange("world.post_spacing_m", dw.post_spacing_m, 1.0, 50.0);
  w.post_radius_m = c.getInRange("world.post_radius_m", dw.post_radius_m, 0.005, 0.3);
  w.post_height_m = c.getInRange("world.post_height_m", dw.post_height_m, 0.2, 5.0);
  w.wire_heights_m = c.get<std::vector<double>>("world.wire_heights_m", dw.wire_heights_m);
  for (double h : w.wire_heights_m)
    if (!(h > 0.0 && h < 5.0))
      fail("{}: world.wire_heights_m: expected heights in (0, 5) m",
           c.location("world.wire_heights_m"));
  w.wire_radius_m = c.getInRange("world.wire_radius_m", dw.wire_radius_m, 0.0, 0.05);
  w.grass_width_m = c.getInRange("world.grass_width_m", dw.grass_width_m, 0.0, 10.0);
  w.backdrop = c.get<bool>("world.backdrop", dw.backdrop);
  w.backdrop_distance_m =
      c.getInRange("world.backdrop_distance_m", dw.backdrop_distance_m, 20.0, 5000.0);
  w.sun_azimuth_deg = c.getInRange("world.sun_azimuth_deg", dw.sun_azimuth_deg, -360.0, 360.0);
  w.sun_elevation_deg = c.getInRange("world.sun_elevation_deg", dw.sun_elevation_deg, 5.0, 90.0);
  w.ground_roughness_m = c.getInRange("world.ground_roughness_m", dw.ground_roughness_m, 0.0, 0.5);
  w.ground_wavelength_m =
      c.getInRange("world.ground_wavelength_m", dw.ground_wavelength_m, 0.2, 100.0);
  if (w.ground_roughness_m > 0.05 * w.ground_wavelength_m)
    fail(
        "{}: world.ground_roughness_m ({} m) must be at most 5 % of world.ground_wavelength_m "
        "({} m): steeper bumps are no ground a wheeled robot drives on",
        c.location("world.ground_roughness_m"), w.ground_roughness_m, w.ground_wavelength_m);
  w.wind_amplitude_m = c.getInRange("world.wind_amplitude_m", dw.wind_amplitude_m, 0.0, 0.5);
  w.wind_period_s = c.getInRange("world.wind_period_s", dw.wind_period_s, 0.1, 100.0);

  TrajectoryOptions& t = s.trajectory;
  const TrajectoryOptions dt;
  t.kind = c.getChoice("trajectory.kind", dt.kind, {"rows", "spin"});
  t.start_hold_s = c.getInRange("trajectory.start_hold_s", dt.start_hold_s, 0.0, 600.0);
  t.end_hold_s = c.getInRange("trajectory.end_hold_s", dt.end_hold_s, 0.0, 600.0);
  t.body_height_m = c.getInRange("trajectory.body_height_m", dt.body_height_m, 0.0, 5.0);
  t.first_interrow = c.getIntInRange("trajectory.first_interrow", dt.first_interrow, 0, 199);
  t.passes = c.getIntInRange("trajectory.passes", dt.passes, 1, 100);
  const int last_interrow = std::max(0, s.world.num_rows - 2);
  if (t.first_interrow > last_interrow)
    fail(
        "{}: key 'trajectory.first_interrow': {} is no interrow of a {}-row world (expected 0 to "
        "{})",
        c.location("trajectory.first_interrow"), t.first_interrow, s.world.num_rows, last_interrow);
  t.first_pass_m = c.getInRange("trajectory.first_pass_m", dt.first_pass_m, 0.0, 1000.0);
  t.last_pass_m = c.getInRange("trajectory.last_pass_m", dt.last_pass_m, 0.0, 1000.0);
  t.headland_entry_m = c.getInRange("trajectory.headland_entry_m", dt.headland_entry_m, 0.0, 50.0);
  t.speed_mps = c.getInRange("trajectory.speed_mps", dt.speed_mps, 0.01, 10.0);
  t.uturn_radius_m = c.getInRange("trajectory.uturn_radius_m", dt.uturn_radius_m, 0.0, 50.0);
  t.uturn_yaw_rate_dps =
      c.getInRange("trajectory.uturn_yaw_rate_dps", dt.uturn_yaw_rate_dps, 1.0, 360.0);
  t.uturn_speed_mps = c.getInRange("trajectory.uturn_speed_mps", dt.uturn_speed_mps, 0.01, 10.0);
  t.turn_left = c.get<bool>("trajectory.turn_left", dt.turn_left);
  t.ramp_s = c.getInRange("trajectory.ramp_s", dt.ramp_s, 0.1, 10.0);
  t.stop_every_m = c.getInRange("trajectory.stop_every_m", dt.stop_every_m, 0.0, 1000.0);
  t.stop_duration_s = c.getInRange("trajectory.stop_duration_s", dt.stop_duration_s, 0.0, 600.0);
  t.spin_deg = c.getInRange("trajectory.spin_deg", dt.spin_deg, -3600.0, 3600.0);
  t.spin_rate_dps = c.getInRange("trajectory.spin_rate_dps", dt.spin_rate_dps, 1.0, 360.0);
  t.lead_in_m = c.getInRange("trajectory.lead_in_m", dt.lead_in_m, 0.0, 1000.0);
  t.lead_out_m = c.getInRange("trajectory.lead_out_m", dt.lead_out_m, 0.0, 1000.0);
  t.start_x_m = c.getInRange("trajectory.start_x_m", dt.start_x_m, -1.0, 1000.0);
  t.bump_sigma_m = c.getInRange("trajectory.bump_sigma_m", dt.bump_sigma_m, 0.0, 0.2);
  t.vibration_sigma_deg =
      c.getInRange("trajectory.vibration_sigma_deg", dt.vibration_sigma_deg, 0.0, 10.0);
  t.vibration_knot_s = c.getInRange("trajectory.vibration_knot_s", dt.vibration_knot_s, 0.01, 1.0);
  t.jitter = c.getInRange("trajectory.jitter", dt.jitter, 0.0, 10.0);

  CameraOptions& cam = s.camera;
  const CameraOptions dc;
  cam.model = c.getChoice("camera.model", dc.model, {"ocam", "pinhole"});
  const std::string calib =
      c.get<std::string>("camera.calibration", "configs/cameras/romovi_ocam.txt");
  if (cam.model == "ocam") cam.calibration = resolveFile(c, "camera.calibration", calib);
  cam.pinhole_width = c.getIntInRange("camera.pinhole.width", dc.pinhole_width, 16, 8192);
  cam.pinhole_height = c.getIntInRange("camera.pinhole.height", dc.pinhole_height, 16, 8192);
  cam.pinhole_hfov_deg = c.getInRange("camera.pinhole.hfov_deg", dc.pinhole_hfov_deg, 10.0, 160.0);
  cam.rate_hz = c.getInRange("camera.rate_hz", dc.rate_hz, 0.1, 1000.0);
  cam.pixel_sigma = c.getInRange("camera.pixel_sigma", dc.pixel_sigma, 0.0, 100.0);
  cam.mount = readMount(c, "camera.mount", dc.mount);
  cam.time_offset_s = c.getInRange("camera.time_offset_s", dc.time_offset_s, -0.5, 0.5);
  cam.rolling_shutter_s = c.getInRange("camera.rolling_shutter_s", dc.rolling_shutter_s, 0.0, 1.0);
  if (cam.rolling_shutter_s >= 1.0 / cam.rate_hz)
    fail("{}: camera.rolling_shutter_s ({} s) must be shorter than the frame period ({} s)",
         c.location("camera.rolling_shutter_s"), cam.rolling_shutter_s, 1.0 / cam.rate_hz);
  cam.frame_drop_probability =
      c.getInRange("camera.frame_drop_probability", dc.frame_drop_probability, 0.0, 0.9);
  cam.auto_exposure = c.get<bool>("camera.auto_exposure", dc.auto_exposure);
  cam.auto_exposure_step =
      c.getInRange("camera.auto_exposure_step", dc.auto_exposure_step, 0.01, 1.0);
  cam.auto_exposure_rate_hz =
      c.getInRange("camera.auto_exposure_rate_hz", dc.auto_exposure_rate_hz, 0.01, 1000.0);

  s.render.supersample = c.getIntInRange("render.supersample", s.render.supersample, 1, 8);
  s.render.footprint_scale =
      c.getInRange("render.footprint_scale", s.render.footprint_scale, 0.25, 4.0);

  NuisanceOptions& n = s.nuisance;
  const NuisanceOptions dn;
  n.exposure_changes = c.get<bool>("nuisance.exposure_changes", dn.exposure_changes);
  n.exposure_amplitude =
      c.getInRange("nuisance.exposure_amplitude", dn.exposure_amplitude, 0.0, 0.9);
  n.exposure_period_s =
      c.getInRange("nuisance.exposure_period_s", dn.exposure_period_s, 0.1, 1000.0);
  n.image_noise = c.get<bool>("nuisance.image_noise", dn.image_noise);
  n.noise_sigma = c.getInRange("nuisance.noise_sigma", dn.noise_sigma, 0.0, 50.0);
  n.shot_noise = c.getInRange("nuisance.shot_noise", dn.shot_noise, 0.0, 10.0);
  n.motion_blur = c.get<bool>("nuisance.motion_blur", dn.motion_blur);
  n.exposure_time_s = c.getInRange("nuisance.exposure_time_s", dn.exposure_time_s, 0.0, 1.0);
  n.blur_samples = c.getIntInRange("nuisance.blur_samples", dn.blur_samples, 2, 64);
  n.people = c.getIntInRange("nuisance.people", dn.people, 0, 100);

  ImuOptions& g = s.imu;
  const ImuOptions dg;
  g.rate_hz = c.getInRange("imu.rate_hz", dg.rate_hz, 1.0, 10000.0);
  g.gyro_noise_density = c.getInRange("imu.gyro_noise_density", dg.gyro_noise_density, 0.0, 1.0);
  g.gyro_bias_random_walk =
      c.getInRange("imu.gyro_bias_random_walk", dg.gyro_bias_random_walk, 0.0, 1.0);
  g.gyro_initial_bias_dps =
      c.getInRange("imu.gyro_initial_bias_dps", dg.gyro_initial_bias_dps, 0.0, 100.0);
  g.accel_noise_density =
      c.getInRange("imu.accel_noise_density", dg.accel_noise_density, 0.0, 10.0);
  g.accel_bias_random_walk =
      c.getInRange("imu.accel_bias_random_walk", dg.accel_bias_random_walk, 0.0, 10.0);
  g.accel_initial_bias = c.getInRange("imu.accel_initial_bias", dg.accel_initial_bias, 0.0, 10.0);
  g.noise = c.get<bool>("imu.noise", dg.noise);
  // Truncated at 3 sigma: at most 0.3 periods, so the stamps stay in order.
  g.time_jitter_s = c.getInRange("imu.time_jitter_s", dg.time_jitter_s, 0.0, 1.0);
  if (g.time_jitter_s > 0.1 / g.rate_hz)
    fail("{}: imu.time_jitter_s ({} s) must be at most a tenth of the sample period ({} s)",
         c.location("imu.time_jitter_s"), g.time_jitter_s, 1.0 / g.rate_hz);

  LidarOptions& l = s.lidar;
  const LidarOptions dl;
  l.rate_hz = c.getInRange("lidar.rate_hz", dl.rate_hz, 0.1, 1000.0);
  l.angle_min_deg = c.getInRange("lidar.angle_min_deg", dl.angle_min_deg, -180.0, 180.0);
  l.angle_max_deg = c.getInRange("lidar.angle_max_deg", dl.angle_max_deg, -180.0, 180.0);
  l.angle_increment_deg =
      c.getInRange("lidar.angle_increment_deg", dl.angle_increment_deg, 0.01, 90.0);
  if (l.angle_max_deg <= l.angle_min_deg)
    fail("{}: lidar.angle_max_deg must exceed lidar.angle_min_deg",
         c.location("lidar.angle_max_deg"));
  l.range_min_m = c.getInRange("lidar.range_min_m", dl.range_min_m, 0.0, 100.0);
  l.range_max_m = c.getInRange("lidar.range_max_m", dl.range_max_m, 0.1, 1000.0);
  if (l.range_max_m <= l.range_min_m)
    fail("{}: lidar.range_max_m must exceed lidar.range_min_m", c.location("lidar.range_max_m"));
  l.range_sigma_m = c.getInRange("lidar.range_sigma_m", dl.range_sigma_m, 0.0, 10.0);
  l.dropout_probability =
      c.getInRange("lidar.dropout_probability", dl.dropout_probability, 0.0, 1.0);
  l.noise = c.get<bool>("lidar.noise", dl.noise);
  l.mount = readMount(c, "lidar.mount", dl.mount);
  l.sweep = c.get<bool>("lidar.sweep", dl.sweep);
  l.scan_time_s = c.getInRange("lidar.scan_time_s", dl.scan_time_s, 0.0, 1000.0);
  if (l.scan_time_s > 0.0 && !l.sweep)
    fail("{}: lidar.scan_time_s is given but lidar.sweep is false (instantaneous scans)",
         c.location("lidar.scan_time_s"));
  if (l.scan_time_s > 1.0 / l.rate_hz * (1.0 + 1e-9))
    fail(
        "{}: lidar.scan_time_s ({} s) must be at most the scan period 1 / lidar.rate_hz ({} s): "
        "a mirror turn cannot outlast its scan",
        c.location("lidar.scan_time_s"), l.scan_time_s, 1.0 / l.rate_hz);

  s.rig.camera_time_offset_s =
      c.getInRange("rig.camera_time_offset_s", s.rig.camera_time_offset_s, -0.5, 0.5);

  const double ratio = cam.rate_hz / l.rate_hz;
  if (std::abs(ratio - std::round(ratio)) > 1e-9 || ratio < 1.0)
    fail(
        "{}: lidar.rate_hz ({}) must divide camera.rate_hz ({}) so that LiDAR stamps fall on "
        "camera "
        "frames",
        c.location("lidar.rate_hz"), l.rate_hz, cam.rate_hz);

  c.checkAllUsed();
  return s;
}

std::string scenarioYaml(const Scenario& s) {
  const auto mount = [](const MountOptions& m) {
    return fmt::format(
        "{{x_m: {}, y_m: {}, z_m: {}, yaw_deg: {}, pitch_down_deg: {}, roll_deg: {}}}", m.x_m,
        m.y_m, m.z_m, m.yaw_deg, m.pitch_down_deg, m.roll_deg);
  };
  const auto b = [](bool v) { return v ? "true" : "false"; };
  const WorldOptions& w = s.world;
  const TrajectoryOptions& t = s.trajectory;
  const CameraOptions& c = s.camera;
  const NuisanceOptions& n = s.nuisance;
  const ImuOptions& g = s.imu;
  const LidarOptions& l = s.lidar;
  std::string y;
  y += "# Effective simulator scenario (ovo simulate). W: z up; B: x forward, y left, z up.\n";
  y += fmt::format("name: {}\nseed: {}\nduration_s: {}\nframes: {}\nstart_time_ns: {}\n", s.name,
                   s.seed, s.duration_s, s.frames, s.start_time_ns);
  y += fmt::format(
      "world:\n  num_rows: {}\n  row_spacing_m: {}\n  row_length_m: {}\n  headland_m: {}\n  "
      "grade_pct: {}\n"
      "  side_tilt_pct: {}\n  canopy_bottom_m: {}\n  canopy_top_m: {}\n  canopy_width_m: {}\n"
      "  canopy_layers: {}\n  leaf_density: {}\n  leaf_size_m: {}\n  plant_spacing_m: {}\n"
      "  gap_probability: {}\n  trunk_radius_m: {}\n  post_spacing_m: {}\n  post_radius_m: {}\n"
      "  post_height_m: {}\n  wire_heights_m: [{}]\n  wire_radius_m: {}\n  grass_width_m: {}\n"
      "  backdrop: {}\n  backdrop_distance_m: {}\n  sun_azimuth_deg: {}\n  sun_elevation_deg: {}\n",
      w.num_rows, w.row_spacing_m, w.row_length_m, w.headland_m, w.grade_pct, w.side_tilt_pct,
      w.canopy_bottom_m, w.canopy_top_m, w.canopy_width_m, w.canopy_layers, w.leaf_density,
      w.leaf_size_m, w.plant_spacing_m, w.gap_probability, w.trunk_radius_m, w.post_spacing_m,
      w.post_radius_m, w.post_height_m, fmt::join(w.wire_heights_m, ", "), w.wire_radius_m,
      w.grass_width_m, b(w.backdrop), w.backdrop_distance_m, w.sun_azimuth_deg,
      w.sun_elevation_deg);
  // The realities added later are written only when on, so that the scenarios that existed
  // before them keep writing the same bytes.
  const WorldOptions dw;
  if (w.ground_roughness_m != dw.ground_roughness_m ||
      w.ground_wavelength_m != dw.ground_wavelength_m)
    y += fmt::format("  ground_roughness_m: {}\n  ground_wavelength_m: {}\n", w.ground_roughness_m,
                     w.ground_wavelength_m);
  if (w.wind_amplitude_m != dw.wind_amplitude_m || w.wind_period_s != dw.wind_period_s)
    y += fmt::format("  wind_amplitude_m: {}\n  wind_period_s: {}\n", w.wind_amplitude_m,
                     w.wind_period_s);
  y += fmt::format(
      "trajectory:\n  kind: {}\n  start_hold_s: {}\n  end_hold_s: {}\n  body_height_m: {}\n"
      "  first_interrow: {}\n  passes: {}\n  first_pass_m: {}\n  last_pass_m: {}\n  "
      "headland_entry_m: {}\n"
      "  speed_mps: {}\n  uturn_radius_m: {}\n  uturn_yaw_rate_dps: {}\n  uturn_speed_mps: {}\n"
      "  turn_left: {}\n  ramp_s: {}\n  stop_every_m: {}\n  stop_duration_s: {}\n  spin_deg: {}\n"
      "  spin_rate_dps: {}\n  lead_in_m: {}\n  lead_out_m: {}\n  start_x_m: {}\n  bump_sigma_m: "
      "{}\n"
      "  vibration_sigma_deg: {}\n  vibration_knot_s: {}\n  jitter: {}\n",
      t.kind, t.start_hold_s, t.end_hold_s, t.body_height_m, t.first_interrow, t.passes,
      t.first_pass_m, t.last_pass_m, t.headland_entry_m, t.speed_mps, t.uturn_radius_m,
      t.uturn_yaw_rate_dps, t.uturn_speed_mps, b(t.turn_left), t.ramp_s, t.stop_every_m,
      t.stop_duration_s, t.spin_deg, t.spin_rate_dps, t.lead_in_m, t.lead_out_m, t.start_x_m,
      t.bump_sigma_m, t.vibration_sigma_deg, t.vibration_knot_s, t.jitter);
  y += fmt::format(
      "camera:\n  model: {}\n  calibration: \"{}\"\n  pinhole: {{width: {}, height: {}, hfov_deg: "
      "{}}}\n"
      "  rate_hz: {}\n  pixel_sigma: {}\n  mount: {}\n",
      c.model, c.calibration.string(), c.pinhole_width, c.pinhole_height, c.pinhole_hfov_deg,
      c.rate_hz, c.pixel_sigma, mount(c.mount));
  const CameraOptions dc;
  if (c.time_offset_s != dc.time_offset_s)
    y += fmt::format("  time_offset_s: {}\n", c.time_offset_s);
  if (c.rolling_shutter_s != dc.rolling_shutter_s)
    y += fmt::format("  rolling_shutter_s: {}\n", c.rolling_shutter_s);
  if (c.frame_drop_probability != dc.frame_drop_probability)
    y += fmt::format("  frame_drop_probability: {}\n", c.frame_drop_probability);
  if (c.auto_exposure != dc.auto_exposure || c.auto_exposure_step != dc.auto_exposure_step ||
      c.auto_exposure_rate_hz != dc.auto_exposure_rate_hz)
    y += fmt::format("  auto_exposure: {}\n  auto_exposure_step: {}\n  auto_exposure_rate_hz: {}\n",
                     b(c.auto_exposure), c.auto_exposure_step, c.auto_exposure_rate_hz);
  y += fmt::format("render:\n  supersample: {}\n  footprint_scale: {}\n", s.render.supersample,
                   s.render.footprint_scale);
  y += fmt::format(
      "nuisance:\n  exposure_changes: {}\n  exposure_amplitude: {}\n  exposure_period_s: {}\n"
      "  image_noise: {}\n  noise_sigma: {}\n  shot_noise: {}\n  motion_blur: {}\n  "
      "exposure_time_s: {}\n"
      "  blur_samples: {}\n  people: {}\n",
      b(n.exposure_changes), n.exposure_amplitude, n.exposure_period_s, b(n.image_noise),
      n.noise_sigma, n.shot_noise, b(n.motion_blur), n.exposure_time_s, n.blur_samples, n.people);
  y += fmt::format(
      "imu:\n  rate_hz: {}\n  gyro_noise_density: {}\n  gyro_bias_random_walk: {}\n"
      "  gyro_initial_bias_dps: {}\n  accel_noise_density: {}\n  accel_bias_random_walk: {}\n"
      "  accel_initial_bias: {}\n  noise: {}\n",
      g.rate_hz, g.gyro_noise_density, g.gyro_bias_random_walk, g.gyro_initial_bias_dps,
      g.accel_noise_density, g.accel_bias_random_walk, g.accel_initial_bias, b(g.noise));
  if (g.time_jitter_s != ImuOptions{}.time_jitter_s)
    y += fmt::format("  time_jitter_s: {}\n", g.time_jitter_s);
  y += fmt::format(
      "lidar:\n  rate_hz: {}\n  angle_min_deg: {}\n  angle_max_deg: {}\n  angle_increment_deg: {}\n"
      "  range_min_m: {}\n  range_max_m: {}\n  range_sigma_m: {}\n  dropout_probability: {}\n  "
      "noise: {}\n"
      "  mount: {}\n",
      l.rate_hz, l.angle_min_deg, l.angle_max_deg, l.angle_increment_deg, l.range_min_m,
      l.range_max_m, l.range_sigma_m, l.dropout_probability, b(l.noise), mount(l.mount));
  const LidarOptions dl;
  if (l.sweep != dl.sweep || l.scan_time_s != dl.scan_time_s)
    y += fmt::format("  sweep: {}\n  scan_time_s: {}\n", b(l.sweep), l.scan_time_s);
  if (s.rig.camera_time_offset_s != RigOptions{}.camera_time_offset_s)
    y += fmt::format("rig:\n  camera_time_offset_s: {}\n", s.rig.camera_time_offset_s);
  return y;
}

}  // namespace ovo::sim
