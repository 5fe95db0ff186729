// Simulated sequences for the estimator comparisons (kf against vo): rendered in-process through
// sim::Simulation from a scenario file, fed to an estimator in time order exactly as the offline
// runner does, and scored with eval (ATE, final yaw, scale error) and the true gyro bias.
#pragma once

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "common/config.hpp"
#include "estimator/estimator.hpp"
#include "eval/align.hpp"
#include "eval/metrics.hpp"
#include "sim/scenario.hpp"
#include "sim/simulation.hpp"
#include "tests/test_support.hpp"

namespace ovo::test {

/// Everything an estimator is fed, plus the simulator's ground truth.
struct SimSequence {
  std::string name;
  estimator::SensorSetup setup{camera::PinholeRadtanCamera(300, 300, 320, 240, 640, 480)};
  std::vector<std::pair<Timestamp, cv::Mat>> images;
  std::vector<ImuSample> imu;
  std::vector<LidarScan> scans;
  Trajectory groundtruth;                                  // T_W_B at every frame
  std::vector<std::pair<Timestamp, Vec3>> true_gyro_bias;  // rad/s
};

/// Renders configs/sim/<scenario>.yaml (scenario keys overridden by `sets`, e.g. "duration_s=9").
inline SimSequence renderSimSequence(const std::string& scenario,
                                     const std::vector<std::string>& sets = {}) {
  Config cfg = Config::load(sourcePath("configs/sim/" + scenario + ".yaml"));
  cfg.applyOverrides(sets);
  sim::Scenario sc = sim::readScenario(cfg);
  const sim::Simulation sim(sc);
  SimSequence seq;
  seq.name = scenario;
  seq.setup.camera = sim.camera();
  seq.setup.T_B_C = sim.T_B_C();
  seq.setup.T_B_L = sim.T_B_L();
  seq.setup.camera_rate_hz = sc.camera.rate_hz;
  seq.setup.pixel_sigma = sc.camera.pixel_sigma;
  seq.setup.camera_height_m = sim.cameraHeightM();
  seq.setup.gyro_noise_density = sc.imu.gyro_noise_density;
  seq.setup.gyro_bias_random_walk = sc.imu.gyro_bias_random_walk;
  seq.setup.lidar_range_sigma_m = sc.lidar.range_sigma_m;
  seq.images.resize(sim.frameCount());
  tbb::parallel_for(0, sim.frameCount(), [&](int k) {
    seq.images[k] = {sim.frameStamp(k), sim.renderFrame(k)};
  });
  std::vector<sim::GyroBiasSample> bias;
  seq.imu = sim.imu(&bias);
  for (const auto& b : bias) seq.true_gyro_bias.emplace_back(b.t_ns, b.bias_radps);
  seq.scans = sim.lidar();
  seq.groundtruth = sim.groundTruth();
  seq.setup.has_gyro = !seq.imu.empty();
  seq.setup.has_lidar = !seq.scans.empty();
  return seq;
}

struct EstimatorRun {
  Trajectory trajectory;
  estimator::EstimatorStats stats;
  std::vector<std::pair<Timestamp, Vec3>> bias_history;
  std::vector<estimator::FrameEstimate> frames;
  Timestamp fed_ahead_ns = 0;  // measurementsUntil(last image) - last image, at the end
};

/// Runs `name` ("vo", "kf", "window") over the sequence in the offline runner's order: the gyro up
/// to the first sample at or after the frame's measurementsUntil, the scans up to it, then the
/// image.
inline EstimatorRun runEstimator(const std::string& name, const SimSequence& seq,
                                 const std::vector<std::string>& sets = {}, bool use_gyro = true,
                                 bool use_lidar = true) {
  Config cfg;
  cfg.applyOverrides(sets);
  estimator::SensorSetup setup = seq.setup;
  setup.has_gyro = setup.has_gyro && use_gyro;
  setup.has_lidar = setup.has_lidar && use_lidar;
  auto est = estimator::makeEstimator(name, setup, cfg);
  static const std::vector<ImuSample> kNoImu;
  static const std::vector<LidarScan> kNoScans;
  const std::vector<ImuSample>& imu = use_gyro ? seq.imu : kNoImu;
  const std::vector<LidarScan>& scans = use_lidar ? seq.scans : kNoScans;
  std::size_t next_imu = 0, next_scan = 0;
  EstimatorRun run;
  for (const auto& [t_ns, grey] : seq.images) {
    estimator::feedUntilImage(est->measurementsUntil(t_ns), imu, next_imu, scans, next_scan, *est);
    run.frames.push_back(est->addImage(t_ns, grey));
    estimator::dropTracks(run.frames.back());
  }
  if (!seq.images.empty())
    run.fed_ahead_ns =
        est->measurementsUntil(seq.images.back().first) - seq.images.back().first;
  est->finish();
  run.trajectory = est->trajectory();
  run.stats = est->stats();
  run.bias_history = est->biasHistory();
  return run;
}

inline bool allPosesFinite(const Trajectory& trajectory) {
  return std::all_of(trajectory.begin(), trajectory.end(),
                     [](const StampedPose& p) { return allFinite(p.T_W_B); });
}

/// The metrics of `ovo run` that the comparisons use.
struct RunScores {
  double ate_m = 0.0;          // SE(3)-aligned ATE RMSE
  double final_yaw_deg = 0.0;  // |yaw error| at the last frame, first poses aligned
  double scale_err_pct = 0.0;  // from the Sim(3) alignment scale
  double length_m = 0.0;
};

inline std::optional<RunScores> scoreRun(const SimSequence& seq, const Trajectory& est) {
  const eval::Associated a = eval::associateByTime(seq.groundtruth, est);
  if (a.size() < 3) return std::nullopt;
  const auto ate = eval::computeAte(a, eval::AlignMode::kSE3);
  const auto origin = eval::alignFirstPose(a.ref, a.est);
  if (!ate || !origin) return std::nullopt;
  const auto yaw = eval::finalYawErrorDeg(a, *origin);
  const auto scale = eval::scaleErrorPct(a);
  if (!yaw || !scale) return std::nullopt;
  return RunScores{ate->trans_m.rmse, std::abs(*yaw), *scale, eval::pathLength(a.ref)};
}

/// Value of a time series at the last sample at or before t (the first sample before it starts).
inline Vec3 sampleAt(const std::vector<std::pair<Timestamp, Vec3>>& series, Timestamp t_ns) {
  auto it = std::upper_bound(series.begin(), series.end(), t_ns,
                             [](Timestamp t, const auto& s) { return t < s.first; });
  if (it != series.begin()) --it;
  return it->second;
}

/// |b_est - b_true| / |b_true| at time t, in percent.
inline double biasErrorPct(const std::vector<std::pair<Timestamp, Vec3>>& estimate,
                           const std::vector<std::pair<Timestamp, Vec3>>& truth, Timestamp t_ns) {
  const Vec3 b_true = sampleAt(truth, t_ns);
  return 100.0 * (sampleAt(estimate, t_ns) - b_true).norm() / std::max(b_true.norm(), 1e-12);
}

}  // namespace ovo::test
