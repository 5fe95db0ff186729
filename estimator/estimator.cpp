#include "estimator/estimator.hpp"

#include "common/error.hpp"
#include "estimator/kf_estimator.hpp"
#include "estimator/vo_estimator.hpp"
#include "estimator/window_estimator.hpp"
#include "estimator/window_options.hpp"

namespace ovo::estimator {

void failFrontendFrame(const char* estimator, bool non_null) {
  if (!non_null) fail("{}: update() got no frame (track() returns one per image)", estimator);
  fail("{}: update() got a frame tracked by another estimator", estimator);
}

std::unique_ptr<Estimator> makeEstimator(const std::string& name, const SensorSetup& setup,
                                         const Config& config) {
  if (name == "vo") return makeVoEstimator(setup, config);
  if (name == "kf") return makeKfEstimator(setup, config);
  if (name == "window") return makeWindowEstimator(setup, config);
  fail("unknown estimator '{}': expected window, kf or vo", name);
}

bool estimatorUsesLidar(const std::string& name, const Config& config) {
  if (name == "kf") return config.get<bool>("kf.use_lidar", KfEstimatorOptions{}.use_lidar);
  if (name == "window") return config.get<bool>("window.use_lidar", WindowOptions{}.use_lidar);
  return false;
}

}  // namespace ovo::estimator
