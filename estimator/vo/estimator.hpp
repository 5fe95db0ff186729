// The plain `vo` chain (DESIGN section 7): frontend relative pose per frame, ground-plane scale,
// poses chained. The dissertation's starting point, kept as a reference (not the product).
#pragma once

#include <memory>

#include "estimator/common/ground_plane.hpp"
#include "estimator/estimator.hpp"

namespace ovo::estimator {

struct VoOptions {
  double camera_height_m = 0.0;  // above the ground; 0 = take the rig's (camera.height_m)
  double max_speed_mps = 40.0;   // a ground-plane scale implying more is rejected (previous used)
  GroundPlaneOptions ground;
  bool operator==(const VoOptions&) const = default;
};
VoOptions readVoOptions(
    const Config& cfg);  // keys vo.camera_height_m, vo.max_speed_mps, vo.ground.*

std::unique_ptr<Estimator> makeVoEstimator(const SensorSetup& setup, const Config& config);

}  // namespace ovo::estimator
