#include "estimator/window_estimator.hpp"

#include "estimator/window_core.hpp"
#include "frontend/frontend.hpp"

namespace ovo::estimator {
namespace {

/// The Estimator: Frontend (with the gyro rotation prior) -> WindowCore.
class WindowEstimator final : public Estimator {
 public:
  WindowEstimator(const SensorSetup& setup, const WindowOptions& options,
                  const frontend::FrontendOptions& frontend_options,
                  const GroundPlaneOptions& ground_options)
      : frontend_(setup.camera, frontend_options),
        core_(setup, options, frontend_options.relative_pose, ground_options) {}

  std::string name() const override { return "window"; }
  void addGyro(const ImuSample& sample) override { core_.addGyro(sample); }
  void addScan(const LidarScan& scan) override { core_.addScan(scan); }

  FrameEstimate addImage(Timestamp t_ns, const cv::Mat& grey) override {
    const auto prior = core_.predictRotationCurPrev(t_ns);
    const frontend::FrontendResult fr = frontend_.process(t_ns, grey, prior);
    VisualFrame frame;
    frame.t_ns = t_ns;
    frame.observations.reserve(fr.observations.size());
    for (const auto& o : fr.observations) {
      if (!o.bearing_C.allFinite() || o.bearing_C.norm() < 0.5) continue;
      frame.observations.push_back(
          {static_cast<TrackId>(o.track_id), o.px, o.bearing_C.normalized(), o.age});
    }
    frame.frontend_ok = !frame.observations.empty();
    FrameEstimate e = core_.processFrame(frame);
    e.frontend_ms = fr.timings.total_ms;
    return e;
  }

  void finish() override { core_.finish(); }
  Trajectory trajectory() const override { return core_.trajectory(); }
  Trajectory keyframes() const override { return core_.keyframes(); }
  EstimatorStats stats() const override { return core_.stats(); }
  std::vector<std::pair<Timestamp, Vec3>> biasHistory() const override {
    return core_.biasHistory();
  }

 private:
  frontend::Frontend frontend_;
  WindowCore core_;
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
