// The `kf` baseline (DESIGN section 7): the dissertation's system rebuilt — the `vo`
// chain, a Kalman filter fusing the gyro with the VO rotation (estimating the gyro bias), and the
// LiDAR scale (ground-plane scale when nothing associates).
#pragma once

#include <memory>

#include "estimator/estimator.hpp"
#include "estimator/kf/options.hpp"

namespace ovo::estimator {

std::unique_ptr<Estimator> makeKfEstimator(const SensorSetup& setup, const Config& config);

}  // namespace ovo::estimator
