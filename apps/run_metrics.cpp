#include "apps/run_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/so3.hpp"
#include "eval/metrics.hpp"

namespace ovo::app {

namespace {

// The entries of v whose index is in [lo, hi) (by the index function), their median; NaN when none.
template <typename T, typename Index, typename Value>
double medianIn(const std::vector<T>& v, std::size_t lo, std::size_t hi, Index index, Value value) {
  std::vector<double> in;
  for (std::size_t k = 0; k < v.size(); ++k) {
    const std::size_t i = index(k);
    if (i >= lo && i < hi) in.push_back(value(k));
  }
  return in.empty() ? std::numeric_limits<double>::quiet_NaN() : percentile(in, 50);
}

nlohmann::json finiteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; }

// Angle between two translation directions [deg]; 180 when the estimate has none.
double directionErrorDeg(const Vec3& t_true, const Vec3& t_est) {
  if (t_est.norm() < 1e-12) return 180.0;  // no motion estimated where there was some: worst case
  const double c = std::clamp(t_true.normalized().dot(t_est.normalized()), -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

// Per consecutive pair: the rotation error of the relative motion [deg]. Per frame i: the angle
// between the estimated and true translation directions [deg] from i to the first later frame j
// that truly moved >= min_move_m away (frame pairs closer than that are too short for a direction
// at 20 Hz and 0.8 m/s), looking at most kMaxSpan frames ahead (a standstill gives no pair).
void perFrameErrors(const eval::Associated& a, double min_move_m, std::vector<double>& rot_deg,
                    std::vector<double>& dir_deg) {
  constexpr std::size_t kMaxSpan = 50;
  for (std::size_t i = 0; i + 1 < a.size(); ++i) {
    const SE3 dQ = a.ref[i].T_W_B.inverse() * a.ref[i + 1].T_W_B;
    const SE3 dP = a.est[i].T_W_B.inverse() * a.est[i + 1].T_W_B;
    rot_deg.push_back(so3::angle(dQ.linear().transpose() * dP.linear()) * 180.0 / M_PI);
    for (std::size_t j = i + 1; j < a.size() && j <= i + kMaxSpan; ++j) {
      const Vec3 tq = a.ref[i].T_W_B.inverse() * a.ref[j].T_W_B.translation();
      if (tq.norm() < min_move_m) continue;
      const Vec3 tp = a.est[i].T_W_B.inverse() * a.est[j].T_W_B.translation();
      dir_deg.push_back(directionErrorDeg(tq, tp));
      break;
    }
  }
}

}  // namespace

nlohmann::json costTrend(const RunTiming& timing) {
  const std::size_t n = timing.total_ms.size();
  if (n < 200) return nullptr;
  const std::size_t warm = n / 20, tenth = n / 10;
  const std::size_t ranges[2][2] = {{warm, warm + tenth}, {n - tenth, n}};
  // The resource samples are placed by the frames handed in, scaled to the frames processed
  // (online runs drop some).
  const double frames_in = timing.resources.empty() ? 0.0 : timing.resources.back().frames;
  const auto sampleFrame = [&](std::size_t k) {
    if (!(frames_in > 0.0)) return n;  // nowhere
    const auto f =
        static_cast<std::size_t>(timing.resources[k].frames / frames_in * static_cast<double>(n));
    return std::min(f, n - 1);
  };
  nlohmann::json out;
  double values[2][4];
  for (int r = 0; r < 2; ++r) {
    const std::size_t lo = ranges[r][0], hi = ranges[r][1];
    double* v = values[r];
    v[0] = medianIn(
        timing.total_ms, lo, hi, [](std::size_t k) { return k; },
        [&](std::size_t k) { return timing.total_ms[k]; });
    v[1] = medianIn(
        timing.keyframe_ms, lo, hi,
        [&](std::size_t k) {
          return k < timing.keyframe_frame.size() ? timing.keyframe_frame[k] : n;
        },
        [&](std::size_t k) { return timing.keyframe_ms[k]; });
    // CPU per frame: from the first to the last sample inside the range.
    v[2] = std::numeric_limits<double>::quiet_NaN();
    std::size_t first = timing.resources.size(), last = 0;
    for (std::size_t k = 0; k < timing.resources.size(); ++k) {
      const std::size_t f = sampleFrame(k);
      if (f < lo || f >= hi) continue;
      first = std::min(first, k);
      last = std::max(last, k);
    }
    if (first < last && timing.resources[last].frames > timing.resources[first].frames)
      v[2] = 1e3 * (timing.resources[last].cpu_s - timing.resources[first].cpu_s) /
             (timing.resources[last].frames - timing.resources[first].frames);
    v[3] = medianIn(
        timing.resources, lo, hi,
        [&](std::size_t k) { return timing.resources[k].rss_mb >= 0.0 ? sampleFrame(k) : n; },
        [&](std::size_t k) { return timing.resources[k].rss_mb; });
    out[r == 0 ? "first" : "last"] = {{"frames", {lo, hi}},
                                      {"frame_ms_median", finiteOrNull(v[0])},
                                      {"keyframe_ms_median", finiteOrNull(v[1])},
                                      {"cpu_ms_per_frame", finiteOrNull(v[2])},
                                      {"rss_mb_median", finiteOrNull(v[3])}};
  }
  const char* names[4] = {"frame_ms", "keyframe_ms", "cpu_per_frame", "rss"};
  for (int i = 0; i < 4; ++i)
    out["ratio"][names[i]] =
        values[0][i] > 0.0 ? finiteOrNull(values[1][i] / values[0][i]) : nlohmann::json(nullptr);
  return out;
}

nlohmann::json computeRunMetrics(const Trajectory& estimate, const Trajectory& groundtruth,
                                 const estimator::EstimatorStats& stats, const RunTiming& timing,
                                 double min_move_m) {
  nlohmann::json m;
  m["frames"] = stats.frames;
  m["frames_tracked"] = stats.frames_tracked;
  m["keyframes"] = stats.keyframes;
  m["lidar_scale_frames"] = stats.lidar_scale_frames;
  m["ground_scale_frames"] = stats.ground_scale_frames;
  m["lidar_keyframes"] = stats.lidar_keyframes;
  m["lidar_ranges"] = stats.lidar_ranges;
  m["gyro_gaps"] = stats.gyro_gaps;
  m["tracking_losses"] = stats.tracking_losses;
  m["solve_failures"] = stats.solve_failures;
  m["marginalization_failures"] = stats.marginalization_failures;
  m["notes"] = stats.notes;
  if (stats.lidar_residuals) {
    // The range factors' fit (window): RMS of predicted minus measured range, in metres and in
    // the LiDAR's range noise, over all keyframes and over the turning ones.
    const estimator::LidarResidualStats& r = *stats.lidar_residuals;
    const auto inSigmas = [&](double metres) {
      return r.range_sigma_m > 0.0 ? metres / r.range_sigma_m : 0.0;
    };
    nlohmann::json& j = m["lidar_residuals"];
    j["count"] = r.count;
    j["rms_m"] = r.rmsM();
    j["rms_sigmas"] = inSigmas(r.rmsM());
    j["range_sigma_m"] = r.range_sigma_m;
    j["rejected"] = r.rejected;
    j["turning_deg_s"] = estimator::LidarResidualStats::kTurningDegS;
    j["turning_count"] = r.turning_count;
    j["turning_rms_m"] = r.turningRmsM();
    j["turning_rms_sigmas"] = inSigmas(r.turningRmsM());
    j["turning_rejected"] = r.turning_rejected;
  }
  if (stats.refine) {
    const estimator::RefineInfo& r = *stats.refine;
    nlohmann::json& j = m["refine"];
    j["usable"] = r.usable;
    j["keyframes"] = r.keyframes;
    j["landmarks"] = r.landmarks;
    j["bearing_factors"] = r.bearing_factors;
    j["lidar_factors"] = r.lidar_factors;
    j["ground_factors"] = r.ground_factors;
    j["removed_outliers"] = r.removed_outliers;
    j["passes"] = r.passes;
    j["iterations"] = r.iterations;
    if (std::isfinite(r.initial_cost)) j["initial_cost"] = r.initial_cost;
    if (std::isfinite(r.final_cost)) j["final_cost"] = r.final_cost;
    j["message"] = r.message;
  }
  m["length_m"] = eval::pathLength(estimate);  // replaced by the true length when known

  if (!groundtruth.empty() && !estimate.empty()) {
    const eval::Associated a = eval::associateByTime(groundtruth, estimate);
    m["gt_pairs"] = a.size();
    if (a.size() >= 3) {
      const double length = eval::pathLength(a.ref);
      m["length_m"] = length;
      if (const auto ate = eval::computeAte(a, eval::AlignMode::kSE3)) {
        m["ate_rmse_m"] = ate->trans_m.rmse;
        if (length > 0) m["ate_pct"] = 100.0 * ate->trans_m.rmse / length;
        m["ate_body_rmse_m"] = {
            {"x", ate->body_rmse_m.x()}, {"y", ate->body_rmse_m.y()}, {"z", ate->body_rmse_m.z()}};
      }
      if (const auto ate = eval::computeAte(a, eval::AlignMode::kSim3))
        m["ate_sim3_rmse_m"] = ate->trans_m.rmse;
      std::vector<double> rot_deg, dir_deg;
      perFrameErrors(a, min_move_m, rot_deg, dir_deg);
      if (!rot_deg.empty()) {
        m["rpe_rot_deg_per_frame_median"] = percentile(rot_deg, 50);
        m["rpe_rot_deg_per_frame_p90"] = percentile(rot_deg, 90);
      }
      if (!dir_deg.empty()) m["rpe_trans_dir_deg_median"] = percentile(dir_deg, 50);
      if (const auto drift = eval::kittiDrift(a)) m["drift_pct"] = drift->trans_pct;
      m["segments"] = segmentsJson<nlohmann::json>(eval::segmentErrors(a));
      if (const auto origin = eval::alignFirstPose(a.ref, a.est)) {
        if (const auto yaw = eval::finalYawErrorDeg(a, *origin))
          m["final_yaw_err_deg"] = std::abs(*yaw);
        const Vec3 p_final = origin->apply(a.est.back().T_W_B.translation());
        m["final_pos_err_m"] = (p_final - a.ref.back().T_W_B.translation()).norm();
        if (length > 0)
          m["final_pos_err_pct"] =
              100.0 * (p_final - a.ref.back().T_W_B.translation()).norm() / length;
      }
      if (const auto s = eval::scaleErrorPct(a)) m["scale_err_pct"] = *s;
    }
  }

  nlohmann::json t;
  t["frontend_ms_median"] = percentile(timing.frontend_ms, 50);
  t["frontend_ms_p90"] = percentile(timing.frontend_ms, 90);
  t["estimator_ms_median"] = percentile(timing.estimator_ms, 50);
  t["estimator_ms_p90"] = percentile(timing.estimator_ms, 90);
  if (!timing.keyframe_ms.empty()) {
    t["keyframe_ms_median"] = percentile(timing.keyframe_ms, 50);
    t["keyframe_ms_p90"] = percentile(timing.keyframe_ms, 90);
    t["keyframe_ms_max"] = percentile(timing.keyframe_ms, 100);
  }
  if (timing.cpu_s >= 0.0) t["cpu_s"] = timing.cpu_s;
  if (const nlohmann::json trend = costTrend(timing); !trend.is_null()) t["trend"] = trend;
  if (timing.peak_rss_mb >= 0.0) t["peak_rss_mb"] = timing.peak_rss_mb;
  t["total_ms_median"] = percentile(timing.total_ms, 50);
  t["total_ms_p90"] = percentile(timing.total_ms, 90);
  t["wall_s"] = timing.wall_s;
  t["realtime_factor"] = timing.wall_s > 0 ? timing.sequence_s / timing.wall_s : 0.0;
  m["timing"] = t;
  if (timing.frames_dropped) {
    m["frames_in"] = timing.frames_in;
    m["frames_dropped"] = *timing.frames_dropped;
    m["latency_ms_median"] = percentile(timing.latency_ms, 50);
    m["latency_ms_p99"] = percentile(timing.latency_ms, 99);
  }
  return m;
}

}  // namespace ovo::app
