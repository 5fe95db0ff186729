// Seeding the keyframes' terrain planes before a solve.
#include "estimator/window/terrain.hpp"

#include <algorithm>

#include "factors/terrain_plane_factor.hpp"

namespace ovo::estimator {

bool usesTerrain(const WindowModel& model) {
  return model.terrain_planes && model.camera_height_m > 0.0;
}

void seedTerrain(const std::vector<Keyframe*>& keyframes, const WindowModel& model) {
  if (!usesTerrain(model)) return;
  const Keyframe* prev = nullptr;
  for (Keyframe* kf : keyframes) {
    if (!kf->terrain_set) {
      if (prev != nullptr)
        std::copy_n(prev->terrain, 3, kf->terrain);
      else
        factors::terrainBelow(kf->pose(), model.T_B_C, model.camera_height_m, kf->terrain);
      kf->terrain_set = true;
    }
    prev = kf;
  }
}

}  // namespace ovo::estimator
