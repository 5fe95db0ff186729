#include "estimator/kf_estimator.hpp"

#include <chrono>
#include <cmath>
#include <deque>

#include "common/so3.hpp"
#include "estimator/kf_filter.hpp"
#include "estimator/lidar_scale.hpp"
#include "estimator/vo_chain.hpp"

namespace ovo::estimator {
namespace {

using Status = frontend::RelativePoseResult::Status;

struct KfEstimatorOptions {
  double camera_height_m = 0.0;       // above the ground; 0 = the rig's (fallback scale)
  double max_speed_mps = 40.0;        // scales implying more are rejected
  double lidar_scale_hold_s = 0.3;    // a LiDAR scale is reused for frames without a scan this long
  double scan_time_tolerance_s = 0.01;  // a scan belongs to a frame within this time
  bool use_gyro = true;
  bool use_lidar = true;
  GroundPlaneOptions ground;
  LidarScaleOptions lidar;
  KfOptions filter;
};

KfEstimatorOptions readKfEstimatorOptions(const Config& cfg, const SensorSetup& setup) {
  KfEstimatorOptions o;
  o.camera_height_m = cfg.getInRange("vo.camera_height_m", o.camera_height_m, 0.0, 100.0);
  o.max_speed_mps = cfg.getInRange("vo.max_speed_mps", o.max_speed_mps, 0.01, 100.0);
  o.lidar_scale_hold_s = cfg.getInRange("kf.lidar_scale_hold_s", o.lidar_scale_hold_s, 0.0, 10.0);
  o.scan_time_tolerance_s = cfg.getInRange("kf.scan_time_tolerance_s", o.scan_time_tolerance_s, 0.0, 1.0);
  o.use_gyro = cfg.get<bool>("kf.use_gyro", o.use_gyro);
  o.use_lidar = cfg.get<bool>("kf.use_lidar", o.use_lidar);
  o.ground = readGroundPlaneOptions(cfg);
  o.lidar = readLidarScaleOptions(cfg);
  // The filter's gyro noise defaults to the rig's figures unless the config sets them.
  Config with_rig = cfg;
  if (!cfg.has("kf.gyro_noise_density"))
    with_rig.applyOverride("kf.gyro_noise_density=" + std::to_string(setup.gyro_noise_density));
  if (!cfg.has("kf.gyro_bias_random_walk"))
    with_rig.applyOverride("kf.gyro_bias_random_walk=" + std::to_string(setup.gyro_bias_random_walk));
  o.filter = readKfOptions(with_rig);
  return o;
}

class KfEstimator final : public Estimator {
 public:
  KfEstimator(const SensorSetup& setup, const Config& config)
      : setup_(setup), options_(readKfEstimatorOptions(config, setup)), chain_(setup.camera, config),
        filter_(options_.filter) {
    up_C_ = setup_.T_B_C.linear().transpose() * Vec3::UnitZ();
    T_C_L_ = cameraFromLidar(setup_.T_B_C, setup_.T_B_L);
    height_m_ = options_.camera_height_m > 0 ? options_.camera_height_m : setup_.camera_height_m.value_or(0.0);
    use_gyro_ = options_.use_gyro && setup_.has_gyro;
    use_lidar_ = options_.use_lidar && setup_.has_lidar;
    if (!use_gyro_) stats_.notes.push_back("kf: no gyro: the filter follows the VO rotation alone");
    if (!use_lidar_)
      stats_.notes.push_back(height_m_ > 0 ? "kf: no LiDAR: ground-plane scale from the camera height"
                                           : "kf: no LiDAR and no camera height: unit scale per frame");
  }

  std::string name() const override { return "kf"; }

  void addGyro(const ImuSample& sample) override {
    if (!use_gyro_ || !sample.gyro_radps.allFinite()) return;
    if (!pending_gyro_.empty() && sample.t_ns <= pending_gyro_.back().t_ns) return;
    pending_gyro_.push_back(sample);
  }

  void addScan(const LidarScan& scan) override {
    if (!use_lidar_) return;
    scans_.push_back(scan);
    while (scans_.size() > 4) scans_.pop_front();
  }

  FrameEstimate addImage(Timestamp t_ns, const cv::Mat& grey) override {
    const auto t0 = std::chrono::steady_clock::now();
    FrameEstimate f;
    f.t_ns = t_ns;
    ++stats_.frames;

    if (!filter_.initialised()) filter_.initialise(t_ns);
    feedGyroUntil(t_ns);

    // Gyro prediction of the camera rotation since the previous frame, for the matcher.
    std::optional<Mat3> prior;
    if (use_gyro_ && !trajectory_.empty()) {
      const Mat3 R_Bprev_Bcur = trajectory_.back().T_W_B.linear().transpose() * predictedRotation(t_ns);
      prior = setup_.T_B_C.linear().transpose() * R_Bprev_Bcur.transpose() * setup_.T_B_C.linear();
    }
    const ChainStep s = chain_.step(t_ns, grey, prior);
    f.frontend_ms = s.frontend_ms;

    if (s.first_frame || trajectory_.empty()) {
      filter_.markFrame(t_ns);
      f.T_W_B = SE3::Identity();
      f.T_W_B.linear() = filter_.R_W_B();
      f.tracked = true;
    } else {
      // The chain measures from its reference frame (older than the previous one while the
      // parallax is small); the filter's clone stays at that reference until the chain moves on.
      const SE3 T_ref = poseAt(s.ref_t_ns);
      const double dt = toSeconds(t_ns - s.ref_t_ns);
      const bool vo_ok = s.status == Status::kOk || s.status == Status::kLowParallax;
      const Mat3& R_B_C = setup_.T_B_C.linear();
      const Mat3 R_Bref_Bcur_vo = R_B_C * s.R_cur_prev.transpose() * R_B_C.transpose();
      if (!vo_ok) {
        filter_.markFrame(t_ns);
      } else if (s.reference_advances) {
        filter_.update(t_ns, R_Bref_Bcur_vo);
      } else {
        filter_.propagateTo(t_ns);
      }
      // The fused rotation; without a gyro the filter cannot follow between VO updates, so the
      // VO rotation from the reference stands in for it there.
      Mat3 R_W_Bcur = filter_.R_W_B();
      if (!use_gyro_ && vo_ok && !s.reference_advances) R_W_Bcur = T_ref.linear() * R_Bref_Bcur_vo;
      const Mat3 R_Bref_Bcur = T_ref.linear().transpose() * R_W_Bcur;
      const Mat3 R_cur_ref = R_B_C.transpose() * R_Bref_Bcur.transpose() * R_B_C;

      Vec3 t_cur_ref = Vec3::Zero();
      f.tracked = vo_ok || use_gyro_;
      SE3 T_base = T_ref;
      if (s.status == Status::kOk) {
        // Translation direction re-estimated for the fused rotation (the VO one as fallback).
        const Vec3 t_unit =
            translationGivenRotation(R_cur_ref, s.bearings_prev, s.bearings_cur).value_or(s.t_cur_prev_unit);
        const double scale = metricScale(t_ns, dt, R_cur_ref, t_unit, s, &f);
        t_cur_ref = scale * t_unit;
      } else if (!vo_ok) {
        f.status = std::string(frontend::toString(s.status));
        ++stats_.tracking_losses;
        T_base = trajectory_.back().T_W_B;  // lost: the position holds, the gyro turns it
      } else {
        f.status = "low_parallax";
      }
      if (!vo_ok) {
        f.T_W_B = T_base;
      } else {
        f.T_W_B = chainPose(T_base, setup_.T_B_C, R_cur_ref, t_cur_ref);
      }
      f.T_W_B.linear() = so3::orthonormalize(R_W_Bcur);
    }
    if (!allFinite(f.T_W_B)) {
      f.T_W_B = trajectory_.empty() ? SE3::Identity() : trajectory_.back().T_W_B;
      f.tracked = false;
      f.status = "non_finite";
    }
    f.gyro_bias = filter_.gyroBias();
    if (f.tracked) ++stats_.frames_tracked;
    trajectory_.push_back({t_ns, f.T_W_B});
    bias_history_.emplace_back(t_ns, filter_.gyroBias());
    f.estimator_ms = std::max(
        0.0, std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count() - s.frontend_ms);
    return f;
  }

  Trajectory trajectory() const override { return trajectory_; }
  EstimatorStats stats() const override { return stats_; }
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const override { return bias_history_; }

 private:
  SE3 poseAt(Timestamp t_ns) const {
    for (auto it = trajectory_.rbegin(); it != trajectory_.rend(); ++it)
      if (it->t_ns == t_ns) return it->T_W_B;
    return trajectory_.back().T_W_B;
  }

  // Propagates the filter with every gyro sample up to t (the rest wait for later frames).
  void feedGyroUntil(Timestamp t_ns) {
    while (!pending_gyro_.empty() && pending_gyro_.front().t_ns <= t_ns) {
      const ImuSample& g = pending_gyro_.front();
      if (last_gyro_t_ && toSeconds(g.t_ns - *last_gyro_t_) > options_.filter.max_gyro_gap_s) ++stats_.gyro_gaps;
      last_gyro_t_ = g.t_ns;
      filter_.propagate(g);
      pending_gyro_.pop_front();
    }
  }

  // The filter's rotation propagated to t without changing the filter (a copy).
  Mat3 predictedRotation(Timestamp t_ns) const {
    KfFilter copy = filter_;
    copy.propagateTo(t_ns);
    return copy.R_W_B();
  }

  double metricScale(Timestamp t_ns, double dt, const Mat3& R_cur_prev, const Vec3& t_unit, const ChainStep& s,
                     FrameEstimate* f) {
    const double max_step = options_.max_speed_mps * std::max(dt, 1e-3);
    std::vector<Vec3> pts;
    std::vector<std::uint8_t> valid;
    triangulateUnit(R_cur_prev, t_unit, s.bearings_prev, s.bearings_cur, &pts, &valid);
    if (use_lidar_) {
      if (const LidarScan* scan = scanAt(t_ns)) {
        std::vector<ScaleFeature> features;
        for (std::size_t i = 0; i < pts.size(); ++i)
          if (valid[i] && i < s.px_cur.size()) features.push_back({pixelOf(s, i), pts[i]});
        const auto est = estimateLidarScale(*scan, T_C_L_, setup_.camera, features, options_.lidar);
        if (est && est->scale > 0 && est->scale <= max_step) {
          ++stats_.lidar_scale_frames;
          f->scale_source_lidar = 1.0;
          last_lidar_t_ = t_ns;
          return setSpeed(est->scale, dt);
        }
      }
      // Frames between scans: the speed of the last LiDAR-scaled step carries on for a while.
      if (last_lidar_t_ && toSeconds(t_ns - *last_lidar_t_) <= options_.lidar_scale_hold_s) {
        ++stats_.lidar_scale_frames;
        f->scale_source_lidar = 1.0;
        return last_speed_mps_ * dt;
      }
    }
    if (height_m_ > 0) {
      std::vector<Vec3> kept;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if (valid[i]) kept.push_back(pts[i]);
      ChainStep tmp;
      tmp.status = Status::kOk;
      tmp.points_cur_unit = std::move(kept);
      const auto g = groundPlaneScale(tmp, up_C_, height_m_, options_.ground);
      if (g && *g <= max_step) {
        ++stats_.ground_scale_frames;
        return setSpeed(*g, dt);
      }
    } else if (!use_lidar_) {
      return 1.0;
    }
    return last_speed_mps_ * dt;  // constant speed through steps without a scale
  }

  double setSpeed(double scale, double dt) {
    if (dt > 0) last_speed_mps_ = scale / dt;
    return scale;
  }

  // Pixel of inlier pair i in the current image (before the triangulation filter of the chain).
  static Vec2 pixelOf(const ChainStep& s, std::size_t i) { return s.px_all_cur[i]; }

  const LidarScan* scanAt(Timestamp t_ns) const {
    for (auto it = scans_.rbegin(); it != scans_.rend(); ++it)
      if (std::abs(toSeconds(it->t_ns - t_ns)) <= options_.scan_time_tolerance_s) return &*it;
    return nullptr;
  }

  SensorSetup setup_;
  KfEstimatorOptions options_;
  VoChain chain_;
  KfFilter filter_;
  Vec3 up_C_;
  SE3 T_C_L_;
  double height_m_ = 0.0;
  bool use_gyro_ = false, use_lidar_ = false;
  std::deque<ImuSample> pending_gyro_;
  std::optional<Timestamp> last_gyro_t_;
  std::deque<LidarScan> scans_;
  double last_speed_mps_ = 0.0;
  std::optional<Timestamp> last_lidar_t_;
  Trajectory trajectory_;
  std::vector<std::pair<Timestamp, Vec3>> bias_history_;
  EstimatorStats stats_;
};

}  // namespace

std::unique_ptr<Estimator> makeKfEstimator(const SensorSetup& setup, const Config& config) {
  return std::make_unique<KfEstimator>(setup, config);
}

}  // namespace ovo::estimator
