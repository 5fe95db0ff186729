// The window estimator: the frontend with the gyro prior feeding the window core.
#include "estimator/window/estimator.hpp"

#include <chrono>
#include <utility>

#include "estimator/common/gyro_front.hpp"
#include "estimator/window/core.hpp"
#include "frontend/frontend.hpp"

namespace ovo::estimator {
namespace {

/// The window's frontend-stage result: the tracked bearings of one image.
struct WindowFrontendFrame : FrontendFrame {
  VisualFrame visual;
};

/// The Estimator: Frontend (with the gyro rotation prior) -> WindowCore.
class WindowEstimator final : public Estimator {
 public:
  WindowEstimator(const SensorSetup& setup, const WindowOptions& options,
                  const frontend::FrontendOptions& frontend_options,
                  const GroundPlaneOptions& ground_options)
      : frontend_(setup.camera, frontend_options),
        frontend_gyro_(kFrontendLeadFrames, gyroFrontOptions(options)),
        core_(setup, options, frontend_options.relative_pose, ground_options),
        R_B_C_(setup.T_B_C.linear()),
        gyro_options_(options.gyro),
        use_gyro_(options.use_gyro && setup.has_gyro) {}

  std::string name() const override { return "window"; }
  void addFrontendGyro(const ImuSample& sample) override {
    if (use_gyro_) frontend_gyro_.add(sample);
  }
  void addEstimatorGyro(const ImuSample& sample) override { core_.addGyro(sample); }
  void addScan(const LidarScan& scan) override { core_.addScan(scan); }
  Timestamp measurementsUntil(Timestamp t_image) const override {
    return core_.measurementsUntil(t_image);
  }

  std::unique_ptr<FrontendFrame> track(Timestamp t_ns, const cv::Mat& grey) override {
    const auto t0 = std::chrono::steady_clock::now();
    const frontend::FrontendResult fr = frontend_.process(t_ns, grey, rotationPrior(t_ns));
    auto frame = std::make_unique<WindowFrontendFrame>();
    frame->t_ns = t_ns;
    VisualFrame& visual = frame->visual;
    visual.t_ns = t_ns;
    visual.observations.reserve(fr.observations.size());
    for (const auto& o : fr.observations) {
      if (o.age >= 2) frame->tracks.push_back({o.track_id, o.px, o.age});
      if (!o.bearing_C.allFinite() || o.bearing_C.norm() < 0.5) continue;
      visual.observations.push_back(
          {static_cast<TrackId>(o.track_id), o.px, o.bearing_C.normalized(), o.age});
    }
    visual.frontend_ok = !visual.observations.empty();
    if (!last_t_ || t_ns > *last_t_) last_t_ = t_ns;
    frame->frontend_ms = msSince(t0);
    return frame;
  }

  FrameEstimate update(std::unique_ptr<FrontendFrame> frame_in) override {
    const auto frame = frontendFrameAs<WindowFrontendFrame>(std::move(frame_in), "window");
    FrameEstimate e = core_.processFrame(std::move(frame->visual));
    frontend_gyro_.publishBias(frame->t_ns, core_.gyroBias());
    e.frontend_ms = frame->frontend_ms;
    e.tracks = std::move(frame->tracks);
    return e;
  }

  void keepHistory(bool keep) override { core_.keepHistory(keep); }
  void finish() override { core_.finish(); }
  Trajectory trajectory() const override { return core_.trajectory(); }
  Trajectory keyframes() const override { return core_.keyframes(); }
  EstimatorStats stats() const override { return core_.stats(); }
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const override {
    return core_.biasHistory();
  }

 private:
  // The gyro-predicted camera rotation from the frontend's previous image to t (bias-corrected),
  // as WindowCore::predictRotationCurPrev computes it, from the frontend stage's own gyro copy.
  std::optional<Mat3> rotationPrior(Timestamp t_ns) {
    if (!use_gyro_ || !last_t_ || t_ns <= *last_t_) return std::nullopt;
    const FrontendGyro::Window w = frontend_gyro_.take(*last_t_, t_ns);
    if (w.samples.empty()) return std::nullopt;
    const factors::GyroPreintegration pi(w.samples, *last_t_, t_ns, w.bias_radps, gyro_options_);
    if (pi.status() == factors::GyroPreintegration::Status::kNoData) return std::nullopt;
    return R_B_C_.transpose() * pi.deltaR().transpose() * R_B_C_;
  }

  // Frontend stage.
  frontend::Frontend frontend_;
  FrontendGyro frontend_gyro_;       // spikes left out as the core's are
  std::optional<Timestamp> last_t_;  // the frontend's previous image
  // Estimator stage.
  WindowCore core_;
  // Constant.
  const Mat3 R_B_C_;
  const factors::GyroPreintegrationOptions gyro_options_;
  const bool use_gyro_;
};

}  // namespace

std::unique_ptr<Estimator> makeWindowEstimator(const SensorSetup& setup, const Config& config) {
  WindowOptions options = readWindowOptions(config);
  if (!config.has("gyro.noise_density")) options.gyro.noise_density = setup.gyro_noise_density;
  const frontend::FrontendOptions frontend_options = frontend::readFrontendOptions(config);
  const GroundPlaneOptions ground_options = readGroundPlaneOptions(config);
  return std::make_unique<WindowEstimator>(setup, options, frontend_options, ground_options);
}

}  // namespace ovo::estimator
