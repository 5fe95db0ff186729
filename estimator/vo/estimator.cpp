// The vo estimator: the chain's steps scaled by the ground plane and chained.
#include "estimator/vo/estimator.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>

#include "estimator/vo/chain.hpp"

namespace ovo::estimator {

VoOptions readVoOptions(const Config& cfg) {
  VoOptions o;
  o.camera_height_m = cfg.getInRange("vo.camera_height_m", o.camera_height_m, 0.0, 100.0);
  o.max_speed_mps = cfg.getInRange("vo.max_speed_mps", o.max_speed_mps, 0.01, 100.0);
  o.ground = readGroundPlaneOptions(cfg);
  return o;
}

namespace {

using Status = frontend::RelativePoseResult::Status;

class VoEstimator final : public Estimator {
 public:
  VoEstimator(const SensorSetup& setup, const Config& config)
      : setup_(setup), options_(readVoOptions(config)), chain_(setup.camera, config) {
    up_C_ = bodyUpIn(setup_.T_B_C);
    height_m_ = options_.camera_height_m > 0 ? options_.camera_height_m
                                             : setup_.camera_height_m.value_or(0.0);
    if (height_m_ <= 0)
      stats_.notes.push_back(
          "vo: no camera height known: translation kept at unit scale per frame");
    if (setup_.has_gyro) stats_.notes.push_back("vo: the gyro is not used by the plain chain");
    if (setup_.has_lidar) stats_.notes.push_back("vo: the LiDAR is not used by the plain chain");
  }

  std::string name() const override { return "vo"; }
  void addEstimatorGyro(const ImuSample&) override {}
  void addScan(const LidarScan&) override {}

  std::unique_ptr<FrontendFrame> track(Timestamp t_ns, const cv::Mat& grey) override {
    return chain_.track(t_ns, grey, std::nullopt, std::chrono::steady_clock::now());
  }

  FrameEstimate update(std::unique_ptr<FrontendFrame> frame_in) override {
    const auto t0 = std::chrono::steady_clock::now();
    const auto frame = frontendFrameAs<ChainFrame>(std::move(frame_in), "vo");
    const ChainStep& s = frame->step;
    const Timestamp t_ns = frame->t_ns;
    FrameEstimate f;
    f.t_ns = t_ns;
    f.frontend_ms = frame->frontend_ms;
    ++stats_.frames;
    if (s.first_frame || trajectory_.empty()) {
      f.T_W_B = SE3::Identity();
      f.tracked = true;
    } else {
      // Motion is measured from the chain's reference frame (older than the previous one while the
      // parallax is small).
      const SE3 T_prev = poseAtOrNewest(trajectory_, s.ref_t_ns);
      const double dt = toSeconds(t_ns - s.ref_t_ns);
      spdlog::debug("vo t={} status={} pairs={} inliers={} points={} ref_dt={:.3f}", t_ns,
                    frontend::toString(s.status), s.matches, s.bearings_cur.size(),
                    s.points_cur_unit.size(), dt);
      if (s.status == Status::kOk) {
        // Without a ground-plane fit this step, the last speed carries on (steps may span
        // several frames while a low-parallax reference is kept).
        double scale = last_speed_mps_ * dt;
        if (height_m_ > 0) {
          const auto g = groundPlaneScale(s, up_C_, height_m_, options_.ground);
          spdlog::debug("vo ground scale {} dt {}", g ? *g : -1.0, dt);
          if (g && *g <= options_.max_speed_mps * std::max(dt, 1e-3)) {
            scale = *g;
            ++stats_.ground_scale_frames;
          }
        } else {
          scale = 1.0;
        }
        if (dt > 0) last_speed_mps_ = scale / dt;
        f.T_W_B = chainPose(T_prev, setup_.T_B_C, s.R_cur_prev, scale * s.t_cur_prev_unit);
        f.tracked = true;
      } else if (s.status == Status::kLowParallax) {
        f.T_W_B = chainPose(T_prev, setup_.T_B_C, s.R_cur_prev, Vec3::Zero());
        f.tracked = true;
        f.status = "low_parallax";
      } else {
        f.T_W_B = trajectory_.back().T_W_B;  // hold: never a guessed pose
        f.tracked = false;
        f.status = std::string(frontend::toString(s.status));
        ++stats_.tracking_losses;
      }
    }
    if (!allFinite(f.T_W_B)) {
      f.T_W_B = trajectory_.empty() ? SE3::Identity() : trajectory_.back().T_W_B;
      f.tracked = false;
      f.status = "non_finite";
    }
    if (f.tracked) ++stats_.frames_tracked;
    f.tracks = std::move(frame->tracks);
    trajectory_.push_back({t_ns, f.T_W_B});
    if (!keep_history_)
      trimHistory(trajectory_, t_ns - fromSeconds(kRecentHistoryS),
                  [](const StampedPose& p) { return p.t_ns; });
    f.estimator_ms = msSince(t0);
    return f;
  }

  void keepHistory(bool keep) override { keep_history_ = keep; }
  Trajectory trajectory() const override { return trajectory_; }
  EstimatorStats stats() const override { return stats_; }

 private:
  SensorSetup setup_;
  VoOptions options_;
  VoChain chain_;
  Vec3 up_C_;
  double height_m_ = 0.0;
  double last_speed_mps_ = 0.0;
  Trajectory trajectory_;
  bool keep_history_ = true;
  EstimatorStats stats_;
};

}  // namespace

std::unique_ptr<Estimator> makeVoEstimator(const SensorSetup& setup, const Config& config) {
  return std::make_unique<VoEstimator>(setup, config);
}

}  // namespace ovo::estimator
