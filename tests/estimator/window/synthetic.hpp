// A small synthetic vineyard for the window estimator's tests, without images: landmarks on two
// canopy slabs and the ground, a robot driving along the inter-row with a gentle yaw weave,
// noisy tracked bearings (exact track ids), a biased noisy gyro and a planar LiDAR ray-cast
// against the same slabs and ground. Deterministic for a seed.
#pragma once

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <random>
#include <tuple>
#include <vector>

#include "camera/calib_io.hpp"
#include "camera/camera.hpp"
#include "common/so3.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/map.hpp"
#include "tests/test_support.hpp"

namespace ovo::test {

struct SyntheticOptions {
  double duration_s = 6.0;
  double camera_rate_hz = 20.0;
  double gyro_rate_hz = 200.0;
  double start_hold_s = 0.5;
  double speed_mps = 0.8;
  double stop_from_s = -1.0, stop_to_s = -1.0;  // a standstill in the middle (s)
  double yaw_amplitude_deg = 3.0;
  double yaw_period_s = 4.0;
  double pixel_sigma = 0.15;    // feature noise (px); the rig says 0.5
  double track_creep_px = 0.0;  // > 0: each track's pixel also random-walks this much per
                                // sqrt(frame) while it is seen, and reports its age (frames)
  Vec3 gyro_bias = Vec3(0.004, -0.003, 0.005);  // rad/s
  double gyro_noise_density = 1.7e-4;
  double gyro_gap_from_s = -1.0, gyro_gap_to_s = -1.0;  // no gyro samples inside (s)
  double lidar_delay_s = 0.0;  // each scan this long after its frame (a LiDAR out of step), s
  double vision_rotation_jitter_rad = 0.0;  // every frame's features are seen as from a camera
                                            // turned by a random rotation of this sigma per axis
                                            // (the same for all of the frame's tracks)
  double vision_drift_radps = 0.0;  // the canopy's tracks are seen as from a camera turned about
                                    // its x axis (a pitch) by this rate times the time (the ground's
                                    // are true): the steady drift of tracks at depth edges
  std::uint32_t seed = 3;
};

struct SyntheticFrame {
  Timestamp t_ns;
  SE3 T_W_B;  // ground truth
  estimator::VisualFrame visual;
};

struct SyntheticSequence {
  estimator::SensorSetup setup{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480), {}, {}};
  std::vector<SyntheticFrame> frames;
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;  // one on every second camera frame (lidar_delay_s after it)
};

inline double syntheticSpeed(const SyntheticOptions& o, double t) {
  auto ramp = [](double x) { return x <= 0 ? 0.0 : x >= 1 ? 1.0 : 0.5 - 0.5 * std::cos(M_PI * x); };
  double v = o.speed_mps * ramp(t - o.start_hold_s);
  if (o.stop_from_s >= 0.0) {
    const double down = ramp((t - o.stop_from_s + 1.0) / 1.0);  // slows over 1 s before the stop
    const double up = ramp(t - o.stop_to_s);
    v *= 1.0 - down + (t >= o.stop_to_s ? up : 0.0);
    if (t >= o.stop_from_s && t < o.stop_to_s) v = 0.0;
  }
  return v;
}

/// One scan of the synthetic vineyard (canopy slabs at y = +-1.25 m, 0.5 to 1.9 m high, and the
/// ground z = 0) by a LiDAR at T_W_L: 541 beams over 270 degrees, 2 cm of range noise (gauss, a
/// standard normal, drawn for each beam that hits); a beam that hits nothing within range_max_m
/// reads 0 (invalid).
inline LidarScan castSyntheticScan(const SE3& T_W_L, Timestamp t_ns, std::mt19937& rng,
                                   std::normal_distribution<double>& gauss,
                                   double range_max_m = 12.0) {
  LidarScan scan;
  scan.t_ns = t_ns;
  scan.angle_min_rad = -135.0 * M_PI / 180.0;
  scan.angle_increment_rad = 0.5 * M_PI / 180.0;
  scan.range_min_m = 0.1;
  scan.range_max_m = range_max_m;
  const Vec3 o_W = T_W_L.translation();
  for (int b = 0; b <= 540; ++b) {
    const double a = scan.angle_min_rad + b * scan.angle_increment_rad;
    const Vec3 d_W = T_W_L.linear() * Vec3(std::cos(a), std::sin(a), 0.0);
    double best = 1e9;
    for (int side = -1; side <= 1; side += 2) {  // canopy slabs
      if (std::abs(d_W.y()) < 1e-9) continue;
      const double s = (side * 1.25 - o_W.y()) / d_W.y();
      const double z = o_W.z() + s * d_W.z();
      if (s > 0 && z > 0.5 && z < 1.9) best = std::min(best, s);
    }
    if (d_W.z() < -1e-9) best = std::min(best, -o_W.z() / d_W.z());  // ground
    scan.ranges_m.push_back(best <= range_max_m ? best + 0.02 * gauss(rng) : 0.0);
  }
  return scan;
}

/// `ocam_calibration`: an OCamCalib file (the tests use the simulator's camera,
/// configs/cameras/romovi_ocam.txt); an ideal 640x480 pinhole when the file does not exist.
inline SyntheticSequence makeSyntheticSequence(const SyntheticOptions& o,
                                               const std::filesystem::path& ocam_calibration) {
  SyntheticSequence seq;
  if (std::filesystem::exists(ocam_calibration))
    seq.setup.camera = camera::loadCamera(ocam_calibration);
  // Rig as in the simulator: camera z along body x, pitched 12 deg down; LiDAR pitched 8 deg.
  Mat3 R_B_C0;
  R_B_C0.col(0) = -Vec3::UnitY();
  R_B_C0.col(1) = -Vec3::UnitZ();
  R_B_C0.col(2) = Vec3::UnitX();
  const Mat3 pitch_c = Eigen::AngleAxisd(12.0 * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix();
  const Mat3 pitch_l = Eigen::AngleAxisd(8.0 * M_PI / 180.0, Vec3::UnitY()).toRotationMatrix();
  seq.setup.T_B_C.linear() = pitch_c * R_B_C0;
  seq.setup.T_B_C.translation() = Vec3(0.35, 0.0, 0.7);
  seq.setup.T_B_L.linear() = pitch_l;
  seq.setup.T_B_L.translation() = Vec3(0.45, 0.0, 0.45);
  seq.setup.camera_rate_hz = o.camera_rate_hz;
  seq.setup.pixel_sigma = 0.5;
  seq.setup.camera_height_m = 0.3 + 0.7;  // body 0.3 m above the ground
  seq.setup.gyro_noise_density = o.gyro_noise_density;
  seq.setup.has_gyro = true;
  seq.setup.has_lidar = true;

  std::mt19937 rng(o.seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  std::normal_distribution<double> gauss(0.0, 1.0);

  // Landmarks: canopy slabs at y = +-1.25 (0.5..1.9 m high) and the ground, x in [-5, 40].
  std::vector<Vec3> points;
  for (int side = -1; side <= 1; side += 2)
    for (int i = 0; i < 3000; ++i) {
      const Vec3 r = draw3(uni, rng);
      points.emplace_back(-5.0 + 45.0 * r.x(), side * (1.25 + 0.1 * (r.y() - 0.5)),
                          0.5 + 1.4 * r.z());
    }
  for (int i = 0; i < 1000; ++i) {
    const Vec2 r = draw2(uni, rng);
    points.emplace_back(-5.0 + 45.0 * r.x(), -1.1 + 2.2 * r.y(), 0.0);
  }

  // Trajectory by integration at 1 kHz.
  const double dt = 1e-3;
  const int steps = static_cast<int>(o.duration_s / dt) + 2;
  std::vector<SE3> poses(steps);
  std::vector<double> yaw_rate(steps);
  double x = 0.0, y = 0.0, psi = 0.0;
  const double w = 2.0 * M_PI / o.yaw_period_s;
  const double amp = o.yaw_amplitude_deg * M_PI / 180.0;
  for (int k = 0; k < steps; ++k) {
    const double t = k * dt;
    const double moving = syntheticSpeed(o, t) / std::max(1e-9, o.speed_mps);
    const double tm = std::max(0.0, t - o.start_hold_s);
    psi = amp * std::sin(w * tm) * moving;
    yaw_rate[k] = 0.0;  // filled by differences below
    SE3 T = SE3::Identity();
    T.linear() = Eigen::AngleAxisd(psi, Vec3::UnitZ()).toRotationMatrix();
    T.translation() = Vec3(x, y, 0.3);
    poses[k] = T;
    const double v = syntheticSpeed(o, t);
    x += v * std::cos(psi) * dt;
    y += v * std::sin(psi) * dt;
  }
  auto yawAt = [&](int k) { return std::atan2(poses[k].linear()(1, 0), poses[k].linear()(0, 0)); };
  for (int k = 0; k + 1 < steps; ++k) yaw_rate[k] = (yawAt(k + 1) - yawAt(k)) / dt;
  yaw_rate[steps - 1] = yaw_rate[steps - 2];
  auto poseAt = [&](double t) {
    return poses[std::min(steps - 1, static_cast<int>(std::lround(t / dt)))];
  };

  // Gyro.
  const double gyro_sigma = o.gyro_noise_density * std::sqrt(o.gyro_rate_hz);
  for (double t = 0.0; t <= o.duration_s + 0.05; t += 1.0 / o.gyro_rate_hz) {
    if (t >= o.gyro_gap_from_s && t < o.gyro_gap_to_s) continue;
    const int k = std::min(steps - 1, static_cast<int>(std::lround(t / dt)));
    ImuSample s;
    s.t_ns = fromSeconds(t);
    s.gyro_radps =
        Vec3(0, 0, yaw_rate[k]) + o.gyro_bias + gyro_sigma * ovo::test::draw3(gauss, rng);
    // The specific force R_W_B^T (a_W - g_W), a_W from the positions' second differences.
    const int k0 = std::clamp(k, 1, steps - 2);
    const Vec3 a_W = (poses[k0 + 1].translation() - 2.0 * poses[k0].translation() +
                      poses[k0 - 1].translation()) /
                     (dt * dt);
    s.accel_mps2 = poses[k].linear().transpose() * (a_W + Vec3(0, 0, 9.81));
    seq.imu.push_back(s);
  }

  // Frames and scans.
  const SE3& T_B_C = seq.setup.T_B_C;
  const int n_frames = static_cast<int>(o.duration_s * o.camera_rate_hz);
  std::vector<std::tuple<int, Vec2, int>> creep(points.size(), {-2, Vec2::Zero(), 0});
  for (int f = 0; f < n_frames; ++f) {
    const double t = f / o.camera_rate_hz;
    SyntheticFrame frame;
    frame.t_ns = fromSeconds(t);
    frame.T_W_B = poseAt(t);
    frame.visual.t_ns = frame.t_ns;
    const Mat3 R_jitter =
        (o.vision_rotation_jitter_rad > 0.0
             ? so3::exp(o.vision_rotation_jitter_rad * ovo::test::draw3(gauss, rng))
             : Mat3::Identity());
    const Mat3 R_drift = so3::exp(Vec3(o.vision_drift_radps * t, 0.0, 0.0));
    const SE3 T_C_W = (frame.T_W_B * T_B_C).inverse();
    for (std::size_t i = 0; i < points.size(); ++i) {
      const bool canopy = points[i].z() > 0.25;
      const Vec3 p_C = (canopy ? R_drift : Mat3::Identity()) * R_jitter * (T_C_W * points[i]);
      const double d = p_C.norm();
      if (d < 0.3 || d > 12.0 || p_C.z() < -0.2 * d) continue;
      const auto px = camera::project(seq.setup.camera, p_C);
      if (!px || !camera::isValid(seq.setup.camera, *px)) continue;
      Vec2 noisy = *px + o.pixel_sigma * ovo::test::draw2(gauss, rng);
      int age = 1;
      if (o.track_creep_px > 0.0) {  // a track lives while its point stays in view
        auto& [last_f, walk_px, track_age] = creep[i];
        if (last_f != f - 1) walk_px.setZero(), track_age = 0;
        walk_px += o.track_creep_px * ovo::test::draw2(gauss, rng);
        last_f = f;
        age = ++track_age;
        noisy += walk_px;
      }
      const auto b = camera::unproject(seq.setup.camera, noisy);
      if (!b) continue;
      frame.visual.observations.push_back({static_cast<estimator::TrackId>(i), noisy, *b, age});
    }
    if (f % 2 == 0) {
      seq.scans.push_back(castSyntheticScan(poseAt(t + o.lidar_delay_s) * seq.setup.T_B_L,
                                            fromSeconds(t + o.lidar_delay_s), rng, gauss));
    }
    seq.frames.push_back(std::move(frame));
  }
  return seq;
}

/// Feeds a sequence to anything with addGyro / addScan / processFrame in the offline runner's
/// order (estimator::feedUntilImage); calls on_frame(index, estimate).
template <typename Core, typename OnFrame>
void feedSequence(const SyntheticSequence& seq, Core& core, OnFrame on_frame) {
  std::size_t next_imu = 0, next_scan = 0;
  for (std::size_t f = 0; f < seq.frames.size(); ++f) {
    const auto& frame = seq.frames[f];
    estimator::feedUntilImage(core.measurementsUntil(frame.t_ns), seq.imu, next_imu, seq.scans,
                              next_scan, core);
    on_frame(f, core.processFrame(frame.visual));
  }
  core.finish();
}

}  // namespace ovo::test
