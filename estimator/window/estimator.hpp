// `--estimator window`, ovo's product (DESIGN section 7): the fisheye Frontend feeds
// tracked bearings to the sliding-window core (estimator/window/core.hpp), which fuses them with
// gyro preintegration and LiDAR ranges in a Ceres keyframe window.
#pragma once

#include <memory>

#include "estimator/estimator.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// Reads "window.", "gyro.", "frontend." and "ransac." keys; the rig's gyro noise density is used
/// unless "gyro.noise_density" is set.
std::unique_ptr<Estimator> makeWindowEstimator(const SensorSetup& setup, const Config& config);

}  // namespace ovo::estimator
