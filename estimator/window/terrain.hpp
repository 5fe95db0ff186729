// The keyframes' terrain planes (window.terrain_planes with a camera height): whether the model
// uses them, and their seeding before a solve.
#pragma once

#include <vector>

#include "estimator/window/map.hpp"
#include "estimator/window/model.hpp"

namespace ovo::estimator {

/// True when the model gives keyframes terrain planes (terrain_planes and a camera height).
bool usesTerrain(const WindowModel& model);
/// Seeds the terrain plane of each keyframe that has none: the previous keyframe's, else the
/// ground below it (factors::terrainBelow). Call before building the factors of a solve.
void seedTerrain(const std::vector<Keyframe*>& keyframes, const WindowModel& model);

}  // namespace ovo::estimator
