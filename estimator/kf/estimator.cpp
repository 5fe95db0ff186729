// The kf estimator: the vo chain's steps fused with the gyro filter, scaled by ground and LiDAR.
#include "estimator/kf/estimator.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <deque>
#include <span>

#include "common/so3.hpp"
#include "estimator/common/gyro_front.hpp"
#include "estimator/common/lidar_deskew.hpp"
#include "estimator/common/lidar_scale.hpp"
#include "estimator/common/two_view.hpp"  // medianParallaxDeg
#include "estimator/kf/filter.hpp"
#include "estimator/vo/chain.hpp"

namespace ovo::estimator {

namespace {

using Status = frontend::RelativePoseResult::Status;

// Metric scale of the kf baseline. With a camera height, each step is scaled by the ground plane
// (libviso2's monocular scale, as in `vo`) times a correction c that the LiDAR estimates:
//   scale_k = c g_k,   g_k = camera_height / ground-plane height of the unit-scale points
// (or the last ground-plane speed times dt when the plane is not seen). A second, uncorrected chain
// (the same rotations, steps g_k t_unit) is checked against the LiDAR along tracks over
// lidar_baseline_s (estimateLidarScaleCorrection): its kappa measures c directly, and
//   x = log c,  x <- x + w (w ~ N(0, scale_walk^2 dt)),  z = log kappa = x + v,
//   v ~ N(0, max(floor^2, (spread / kappa)^2 / n))
// is a scalar Kalman filter. A wrong camera height or a slanted ground (which bias g_k) are what c
// absorbs. One LiDAR measurement is good to a few percent (few beams land on tracked features),
// the ground plane to a fraction of one when the height is right, so c is applied only once it is
// significant: |x| > scale_deadband and |x| > 3 sqrt(P) (then fully; until |x| falls below half
// the deadband). Without a camera height the LiDAR scales each step directly (estimateLidarScale on
// the unit-scale points).
class KfEstimator final : public Estimator {
 public:
  KfEstimator(const SensorSetup& setup, const Config& config)
      : setup_(setup),
        options_(readKfEstimatorOptions(config, setup)),
        chain_(setup.camera, config),
        frontend_gyro_(kFrontendLeadFrames, gyroFrontOptions(options_)),
        filter_(options_.filter),
        gyro_(gyroFrontOptions(options_)) {
    up_C_ = bodyUpIn(setup_.T_B_C);
    T_C_L_ = cameraFromLidar(setup_.T_B_C, setup_.T_B_L);
    height_m_ = options_.camera_height_m > 0 ? options_.camera_height_m
                                             : setup_.camera_height_m.value_or(0.0);
    use_gyro_ = options_.use_gyro && setup_.has_gyro;
    use_lidar_ = options_.use_lidar && setup_.has_lidar;
    log_c_var_ = options_.scale_sigma0 * options_.scale_sigma0;
    if (use_lidar_ && height_m_ > 0) chain_.setHistorySpan(fromSeconds(options_.lidar_baseline_s));
    if (!use_gyro_)
      stats_.notes.push_back(
          setup_.has_gyro
              ? "kf: gyro switched off (kf.use_gyro): the filter follows the VO rotation alone"
              : "kf: no gyro: the filter follows the VO rotation alone");
    if (!use_lidar_)
      stats_.notes.push_back(height_m_ > 0
                                 ? "kf: no LiDAR: ground-plane scale from the camera height"
                                 : "kf: no LiDAR and no camera height: unit scale per frame");
    else if (height_m_ <= 0)
      stats_.notes.push_back(
          "kf: no camera height: LiDAR scale per frame, the last speed between scans");
  }

  std::string name() const override { return "kf"; }

  void addFrontendGyro(const ImuSample& sample) override {
    if (use_gyro_) frontend_gyro_.add(sample);
  }

  void addEstimatorGyro(const ImuSample& sample) override {
    if (!use_gyro_) return;
    if (gyro_.add(sample) == GyroFront::Intake::kSpike && !said_spikes_) {
      stats_.notes.push_back(fmt::format(
          "kf: gyro samples whose rate jumped by more than {} rad/s in one sample were left out "
          "as spikes",
          options_.gyro_max_jump_radps));
      said_spikes_ = true;
    }
  }

  void addScan(const LidarScan& scan) override {
    if (!use_lidar_) return;
    scans_.push_back(scan);
    while (scans_.size() > 4) scans_.pop_front();
  }

  std::unique_ptr<FrontendFrame> track(Timestamp t_ns, const cv::Mat& grey) override {
    const auto t0 = std::chrono::steady_clock::now();
    // Gyro prediction of the camera rotation since the previous frame, for the matcher.
    std::optional<Mat3> prior;
    if (use_gyro_ && frontend_last_t_ && t_ns > *frontend_last_t_) {
      const FrontendGyro::Window w = frontend_gyro_.take(*frontend_last_t_, t_ns);
      const Mat3 R_Bprev_Bcur = predictGyroRotation(w.samples, *frontend_last_t_, t_ns,
                                                    w.bias_radps, options_.filter.max_gyro_gap_s);
      prior = setup_.T_B_C.linear().transpose() * R_Bprev_Bcur.transpose() * setup_.T_B_C.linear();
    }
    if (!frontend_last_t_ || t_ns > *frontend_last_t_) frontend_last_t_ = t_ns;
    return chain_.track(t_ns, grey, prior, t0);
  }

  FrameEstimate update(std::unique_ptr<FrontendFrame> frame_in) override {
    const auto t0 = std::chrono::steady_clock::now();
    const auto frame = frontendFrameAs<ChainFrame>(std::move(frame_in), "kf");
    const ChainStep& s = frame->step;
    const Timestamp t_ns = frame->t_ns;
    FrameEstimate f;
    f.t_ns = t_ns;
    f.frontend_ms = frame->frontend_ms;
    f.tracks = std::move(frame->tracks);
    ++stats_.frames;

    if (!filter_.initialised()) filter_.initialise(t_ns);
    feedGyroUntil(t_ns);
    SE3 T_W_B_base = SE3::Identity();  // the uncorrected (ground-plane scale) chain

    if (s.first_frame || trajectory_.empty()) {
      filter_.markFrame(t_ns);
      f.T_W_B = SE3::Identity();
      f.T_W_B.linear() = filter_.R_W_B();
      T_W_B_base = f.T_W_B;
      f.tracked = true;
    } else {
      // The chain measures from its reference frame (older than the previous one while the
      // parallax is small); the filter's clone stays at that reference until the chain moves on.
      const SE3 T_ref = poseAtOrNewest(trajectory_, s.ref_t_ns);
      const SE3 T_ref_base = poseAtOrNewest(base_trajectory_, s.ref_t_ns);
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
      if (vo_ok && use_gyro_ && options_.zero_rate_update && standingStill(s))
        holdZeroRate(t_ns, frame_gyro_.mean(), toSeconds(t_ns - trajectory_.back().t_ns));
      else
        held_zero_rate_.clear();  // moving (or unsure): the last still-looking frames were not
      // The fused rotation; without a gyro the filter cannot follow between VO updates, so the
      // VO rotation from the reference stands in for it there.
      Mat3 R_W_Bcur = filter_.R_W_B();
      if (!use_gyro_ && vo_ok && !s.reference_advances) R_W_Bcur = T_ref.linear() * R_Bref_Bcur_vo;
      R_W_Bcur = so3::orthonormalize(R_W_Bcur);
      const Mat3 R_Bref_Bcur = T_ref.linear().transpose() * R_W_Bcur;
      const Mat3 R_cur_ref = R_B_C.transpose() * R_Bref_Bcur.transpose() * R_B_C;

      f.tracked = vo_ok || use_gyro_;
      if (s.status == Status::kOk) {
        // Translation direction re-estimated for the fused rotation (the VO one as fallback).
        const Vec3 t_unit =
            options_.refit_translation
                ? translationGivenRotation(R_cur_ref, s.bearings_prev, s.bearings_cur)
                      .value_or(s.t_cur_prev_unit)
                : s.t_cur_prev_unit;
        const auto [scale, base_scale] = metricScale(t_ns, dt, R_cur_ref, t_unit, s, &f);
        f.T_W_B = chainPose(T_ref, setup_.T_B_C, R_cur_ref, scale * t_unit);
        T_W_B_base = chainPose(T_ref_base, setup_.T_B_C, R_cur_ref, base_scale * t_unit);
      } else if (vo_ok) {
        f.status = "low_parallax";
        f.T_W_B = chainPose(T_ref, setup_.T_B_C, R_cur_ref, Vec3::Zero());
        T_W_B_base = chainPose(T_ref_base, setup_.T_B_C, R_cur_ref, Vec3::Zero());
      } else {
        f.status = std::string(frontend::toString(s.status));
        ++stats_.tracking_losses;
        f.T_W_B = trajectory_.back().T_W_B;  // lost: the position holds, the gyro turns it
        T_W_B_base = base_trajectory_.back().T_W_B;
      }
      f.T_W_B.linear() = R_W_Bcur;
      T_W_B_base.linear() = R_W_Bcur;
    }
    if (!allFinite(f.T_W_B) || !allFinite(T_W_B_base)) {
      f.T_W_B = trajectory_.empty() ? SE3::Identity() : trajectory_.back().T_W_B;
      T_W_B_base = base_trajectory_.empty() ? SE3::Identity() : base_trajectory_.back().T_W_B;
      f.tracked = false;
      f.status = "non_finite";
    }
    f.gyro_bias = filter_.gyroBias();
    frontend_gyro_.publishBias(t_ns, f.gyro_bias);
    if (f.tracked) ++stats_.frames_tracked;
    if (trajectory_.empty()) first_t_ns_ = t_ns;
    trajectory_.push_back({t_ns, f.T_W_B});
    base_trajectory_.push_back({t_ns, T_W_B_base});
    bias_history_.emplace_back(t_ns, filter_.gyroBias());
    if (!keep_history_) {
      const Timestamp keep_from = t_ns - fromSeconds(kRecentHistoryS);
      trimHistory(trajectory_, keep_from, [](const StampedPose& p) { return p.t_ns; });
      trimHistory(bias_history_, keep_from, [](const auto& b) { return b.first; });
    }
    if (s.status == Status::kOk && use_lidar_ && height_m_ > 0) updateScaleCorrection(t_ns, s);
    // Poses older than the LiDAR baseline are no longer looked up.
    while (!base_trajectory_.empty() &&
           toSeconds(t_ns - base_trajectory_.front().t_ns) > 2.0 * options_.lidar_baseline_s + 1.0)
      base_trajectory_.pop_front();
    f.estimator_ms = msSince(t0);
    return f;
  }

  void finish() override {
    if (still_frames_ > 0)
      stats_.notes.push_back(
          fmt::format("kf: standing still in {} frames: gyro bias from zero-rate updates there",
                      still_frames_));
    if (use_lidar_ && stats_.lidar_scale_frames == 0)
      stats_.notes.push_back(
          "kf: the LiDAR never associated with tracked features: ground-plane scale only");
  }

  void keepHistory(bool keep) override { keep_history_ = keep; }
  Trajectory trajectory() const override { return trajectory_; }
  EstimatorStats stats() const override { return stats_; }
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const override { return bias_history_; }

 private:
  std::optional<SE3> basePoseAt(Timestamp t_ns) const {
    auto it = std::lower_bound(base_trajectory_.begin(), base_trajectory_.end(), t_ns,
                               [](const StampedPose& p, Timestamp t) { return p.t_ns < t; });
    if (it == base_trajectory_.end() || it->t_ns != t_ns) return std::nullopt;
    return it->T_W_B;
  }

  // Standstill: the image does not move (median angle between the reference's and the current
  // bearings of the tracked pairs, no rotation compensation: a still camera sees the same rays)
  // and the gyro samples of the frame are quiet (only sensor noise; vibration or turning is not).
  bool standingStill(const ChainStep& s) const {
    if (frame_gyro_.count < 3 || s.bearings_prev.size() < 8) return false;
    if (frame_gyro_.spread() > options_.still_gyro_std_radps) return false;
    return medianParallaxDeg(s.bearings_prev, s.bearings_cur, Mat3::Identity()) <
           options_.still_flow_deg;
  }

  // A still frame's zero-rate measurement waits in held_zero_rate_ until the standstill has
  // lasted still_trim_s past it (then it updates the filter), or is dropped when the motion starts
  // first: the frames just before motion is seen (slow start, flow below still_flow_deg, smooth
  // rates) are often moving already.
  void holdZeroRate(Timestamp t_ns, const Vec3& mean_rate_radps, double window_s) {
    held_zero_rate_.push_back({t_ns, mean_rate_radps, window_s});
    const Timestamp trim_ns = fromSeconds(options_.still_trim_s);
    while (!held_zero_rate_.empty() && t_ns - held_zero_rate_.front().t_ns >= trim_ns) {
      const HeldZeroRate& z = held_zero_rate_.front();
      if (filter_.zeroRateUpdate(z.mean_rate_radps, z.window_s).applied) ++still_frames_;
      held_zero_rate_.pop_front();
    }
  }

  // Propagates the filter with every gyro sample up to t (the rest wait for later frames), and
  // keeps the mean and spread of this frame's samples for the standstill test.
  void feedGyroUntil(Timestamp t_ns) {
    frame_gyro_ = {};
    const auto& samples = gyro_.samples();
    auto it = samples.begin();
    if (last_gyro_t_)
      it = std::upper_bound(samples.begin(), samples.end(), *last_gyro_t_,
                            [](Timestamp t, const ImuSample& g) { return t < g.t_ns; });
    for (; it != samples.end() && it->t_ns <= t_ns; ++it) {
      const ImuSample& g = *it;
      frame_gyro_.add(g.gyro_radps);
      if (last_gyro_t_ && toSeconds(g.t_ns - *last_gyro_t_) > options_.filter.max_gyro_gap_s)
        ++stats_.gyro_gaps;
      last_gyro_t_ = g.t_ns;
      filter_.propagate(g);
    }
    // What is left: the samples not yet fed, and the last kRecentGyroS before them for the
    // scans' sweeps (deskewed).
    if (last_gyro_t_) gyro_.dropBefore(*last_gyro_t_ - fromSeconds(kRecentGyroS));
  }

  // {scale of this step, scale of the uncorrected chain}; see the model above the class.
  std::pair<double, double> metricScale(Timestamp t_ns, double dt, const Mat3& R_cur_ref,
                                        const Vec3& t_unit, const ChainStep& s, FrameEstimate* f) {
    const double max_step = options_.max_speed_mps * std::max(dt, 1e-3);
    std::vector<Vec3> pts;
    std::vector<std::uint8_t> valid;
    triangulateUnit(R_cur_ref, t_unit, s.bearings_prev, s.bearings_cur, &pts, &valid);
    if (height_m_ <= 0) {
      const double scale = use_lidar_ ? directLidarScale(t_ns, dt, pts, valid, s, f) : 1.0;
      return {scale, scale};
    }
    double g = ground_speed_mps_ * dt;  // constant speed through steps without a ground fit
    std::vector<Vec3> kept;
    for (std::size_t i = 0; i < pts.size(); ++i)
      if (valid[i]) kept.push_back(pts[i]);
    ChainStep tmp;
    tmp.status = Status::kOk;
    tmp.points_cur_unit = std::move(kept);
    if (const auto fit = groundPlaneScale(tmp, up_C_, height_m_, options_.ground);
        fit && *fit <= max_step) {
      g = *fit;
      if (dt > 0) ground_speed_mps_ = g / dt;
    }
    const bool lidar_recent =
        last_lidar_t_ && toSeconds(t_ns - *last_lidar_t_) <= options_.lidar_scale_hold_s;
    if (lidar_recent) {
      ++stats_.lidar_scale_frames;
      f->scale_source_lidar = 1.0;
    } else {
      ++stats_.ground_scale_frames;
    }
    return {(scale_applied_ ? std::exp(log_c_) : 1.0) * g, g};
  }

  // Without a camera height: scale = estimateLidarScale on this step's unit-scale points; the last
  // LiDAR speed between scans.
  double directLidarScale(Timestamp t_ns, double dt, const std::vector<Vec3>& pts,
                          const std::vector<std::uint8_t>& valid, const ChainStep& s,
                          FrameEstimate* f) {
    const double max_step = options_.max_speed_mps * std::max(dt, 1e-3);
    if (const LidarScan* raw = scanAt(t_ns)) {
      const LidarScan scan = deskewed(*raw);
      std::vector<ScaleFeature> features;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if (valid[i] && i < s.px_all_cur.size()) features.push_back({s.px_all_cur[i], pts[i]});
      const auto est = estimateLidarScale(scan, T_C_L_, setup_.camera, features, options_.lidar);
      if (est && est->scale > 0 && est->scale <= max_step) {
        ++stats_.lidar_scale_frames;
        f->scale_source_lidar = 1.0;
        last_lidar_t_ = t_ns;
        if (dt > 0) lidar_speed_mps_ = est->scale / dt;
        return est->scale;
      }
    }
    if (last_lidar_t_ && toSeconds(t_ns - *last_lidar_t_) <= options_.lidar_scale_hold_s) {
      ++stats_.lidar_scale_frames;
      f->scale_source_lidar = 1.0;
    }
    return lidar_speed_mps_ * dt;
  }

  // The LiDAR's measurement of c = exp(x) on the uncorrected chain, and the scalar KF update.
  void updateScaleCorrection(Timestamp t_ns, const ChainStep& s) {
    const LidarScan* raw = scanAt(t_ns);
    if (!raw) return;
    const LidarScan scan = deskewed(*raw);
    const SE3 T_W_Ccur = base_trajectory_.back().T_W_B * setup_.T_B_C;
    std::vector<TrackScaleFeature> features;
    const double max_rotation_rad = options_.lidar_max_rotation_deg * M_PI / 180.0;
    // This step's inliers (tracks that agree with the epipolar geometry since the reference).
    for (std::size_t i = 0; i < s.track_history.size() && i < s.px_all_cur.size(); ++i) {
      // The oldest observation within the baseline span (ChainStep::track_history) whose pose
      // is known.
      for (const auto& obs : s.track_history[i]) {
        const auto T_W_Bold = basePoseAt(obs.t_ns);
        if (!T_W_Bold) continue;
        const SE3 T_W_Cold = *T_W_Bold * setup_.T_B_C;
        const SE3 T_Cold_Ccur = T_W_Cold.inverse() * T_W_Ccur;
        // The turn about the world's up (the rotation vector in W): a robot turning on the spot
        // turns about it; one pitching and rolling over rough ground does not.
        const double turn_rad = std::abs((T_W_Cold.linear() * so3::log(T_Cold_Ccur.linear())).z());
        if (T_Cold_Ccur.translation().norm() >= options_.lidar_min_baseline_m &&
            turn_rad <= max_rotation_rad)
          features.push_back({s.px_all_cur[i], s.bearings_cur[i], obs.bearing_C,
                              T_Cold_Ccur.linear(), T_Cold_Ccur.translation()});
        break;
      }
    }
    const Vec3 up_C = T_W_Ccur.linear().transpose() * Vec3::UnitZ();
    const auto kappa = estimateLidarScaleCorrection(scan, T_C_L_, setup_.camera, features, up_C,
                                                    height_m_, options_.lidar);
    if (!kappa || !(kappa->scale > 0)) return;
    if (last_scale_update_t_)
      log_c_var_ +=
          options_.scale_walk * options_.scale_walk * toSeconds(t_ns - *last_scale_update_t_);
    last_scale_update_t_ = t_ns;
    const double z = std::log(kappa->scale);
    const double rel_spread = kappa->spread / kappa->scale;
    const double r = std::max(options_.scale_noise_floor * options_.scale_noise_floor,
                              rel_spread * rel_spread / std::max(kappa->associations, 1));
    const double innovation = z - log_c_;
    const double S = log_c_var_ + r;
    if (options_.scale_gate_chi2 > 0 && innovation * innovation / S > options_.scale_gate_chi2)
      return;
    const double K = log_c_var_ / S;
    log_c_ += K * innovation;
    log_c_var_ *= 1.0 - K;
    last_lidar_t_ = t_ns;
    const double x = std::abs(log_c_);
    if (!scale_applied_ && x > options_.scale_deadband && x > 3.0 * std::sqrt(log_c_var_)) {
      scale_applied_ = true;
      if (!said_applied_) {
        stats_.notes.push_back(fmt::format(
            "kf: the LiDAR corrects the ground-plane scale by {:+.1f} % (from {:.1f} s on)",
            100.0 * (std::exp(log_c_) - 1.0), toSeconds(t_ns - first_t_ns_)));
        said_applied_ = true;
      }
    } else if (scale_applied_ && x < 0.5 * options_.scale_deadband) {
      scale_applied_ = false;
    }
  }

  // The scan made instantaneous at its stamp (options_.lidar_deskew; scans with per-beam times):
  // the body turned at the gyro's mean rate over the sweep, less the filter's bias. The kf's own
  // velocity (the chain's, over the last frames) is left out: it tightened the LiDAR's scale
  // measurements on a straight row but biased them through a headland pivot (docs/simulator.md).
  LidarScan deskewed(const LidarScan& scan) const {
    if (!options_.lidar_deskew || !use_gyro_) return scan;
    return deskewScanWithGyro(scan, gyro_.samples(), filter_.gyroBias(), Vec3::Zero(),
                              setup_.T_B_L);
  }

  const LidarScan* scanAt(Timestamp t_ns) const {
    for (auto it = scans_.rbegin(); it != scans_.rend(); ++it)
      if (std::abs(toSeconds(it->t_ns - t_ns)) <= options_.scan_time_tolerance_s) return &*it;
    return nullptr;
  }

  SensorSetup setup_;
  KfEstimatorOptions options_;
  // Frontend stage.
  VoChain chain_;
  FrontendGyro frontend_gyro_;                // spikes left out as the filter's are
  std::optional<Timestamp> frontend_last_t_;  // the frontend's previous image
  // Estimator stage.
  KfFilter filter_;
  Vec3 up_C_;
  SE3 T_C_L_;
  double height_m_ = 0.0;
  bool use_gyro_ = false, use_lidar_ = false;
  GyroFront gyro_;  // the samples not yet fed to the filter and the last kRecentGyroS before
  bool said_spikes_ = false;
  std::optional<Timestamp> last_gyro_t_;
  GyroScatter frame_gyro_;  // the gyro samples fed for the current frame
  int still_frames_ = 0;    // frames with a zero-rate update
  struct HeldZeroRate {
    Timestamp t_ns = 0;
    Vec3 mean_rate_radps = Vec3::Zero();
    double window_s = 0.0;
  };
  std::deque<HeldZeroRate> held_zero_rate_;  // still frames waiting for still_trim_s more
  std::deque<LidarScan> scans_;
  static constexpr double kRecentGyroS = 1.0;  // gyro kept for the scans' sweeps, s
  double ground_speed_mps_ = 0.0;              // last ground-plane speed (uncorrected)
  double lidar_speed_mps_ = 0.0;               // last direct LiDAR speed (no camera height)
  double log_c_ = 0.0;                         // x = log(LiDAR / ground-plane scale)
  double log_c_var_ = 0.0;
  bool scale_applied_ = false;  // c significant (see the model above the class)
  bool said_applied_ = false;
  std::optional<Timestamp> last_scale_update_t_;
  std::optional<Timestamp> last_lidar_t_;
  Trajectory trajectory_;
  bool keep_history_ = true;
  Timestamp first_t_ns_ = 0;  // the first frame's
  std::deque<StampedPose> base_trajectory_;
  std::vector<std::pair<Timestamp, Vec3>> bias_history_;
  EstimatorStats stats_;
};

}  // namespace

std::unique_ptr<Estimator> makeKfEstimator(const SensorSetup& setup, const Config& config) {
  return std::make_unique<KfEstimator>(setup, config);
}

}  // namespace ovo::estimator
