// The estimator factory (by name) and the interface's shared helpers.
#include "estimator/estimator.hpp"

#include <cmath>

#include "common/error.hpp"
#include "estimator/kf/estimator.hpp"
#include "estimator/vo/estimator.hpp"
#include "estimator/window/estimator.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

void failFrontendFrame(const char* estimator, bool non_null) {
  if (!non_null) fail("{}: update() got no frame (track() returns one per image)", estimator);
  fail("{}: update() got a frame tracked by another estimator", estimator);
}

double LidarResidualStats::rmsM() const { return count > 0 ? std::sqrt(sum_sq_m2 / count) : 0.0; }

double LidarResidualStats::turningRmsM() const {
  return turning_count > 0 ? std::sqrt(turning_sum_sq_m2 / turning_count) : 0.0;
}

std::vector<std::string> applyNoiseFloors(SensorSetup& setup) {
  std::vector<std::string> notes;
  const auto raise = [&](double& value, double floor, const char* what, const char* unit) {
    if (value >= floor) return;
    notes.push_back(fmt::format("rig {} {} {} is below what the estimator can weigh: {} {} used",
                                what, value, unit, floor, unit));
    value = floor;
  };
  raise(setup.pixel_sigma, 0.05, "camera.pixel_sigma", "px");
  raise(setup.gyro_noise_density, 1e-6, "gyro.noise_density", "rad/s/sqrt(Hz)");
  raise(setup.gyro_bias_random_walk, 1e-7, "gyro.bias_random_walk", "rad/s^2/sqrt(Hz)");
  raise(setup.lidar_range_sigma_m, 1e-3, "lidar.range_sigma_m", "m");
  return notes;
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
