// The plain `vo` chain (DESIGN section 7): frontend relative pose per frame, ground-plane scale,
// poses chained. The dissertation's starting point, kept as a reference (not the product).
#pragma once

#include <memory>

#include "estimator/estimator.hpp"

namespace ovo::estimator {

std::unique_ptr<Estimator> makeVoEstimator(const SensorSetup& setup, const Config& config);

}  // namespace ovo::estimator
