// Rescaling every length-carrying state of the window about its oldest keyframe.
#include "estimator/window/rescale.hpp"

#include <vector>

#include "factors/terrain_plane_factor.hpp"

namespace ovo::estimator {

void rescaleWindow(double s, WindowMap& map, WindowGauge& gauge, FrameLog& frames,
                   const MotionState& motion, const SE3& T_B_L) {
  const Vec3 centre = map.keyframes.front()->pose().translation();
  const factors::TerrainScaling terrain = factors::terrainScaling(centre, s);
  std::vector<factors::MarginalizationInfo::BlockMap> moved;
  for (auto& kf : map.keyframes) {
    Eigen::Map<Vec3> p(kf->p_W_B);
    p = centre + s * (p - centre);
    moved.push_back(factors::MarginalizationInfo::scaling(kf->p_W_B, centre, s));
    if (kf->terrain_set) factors::scaleTerrain(kf->terrain, centre, s);
    moved.push_back({kf->terrain, terrain.M, terrain.k});
    kf->lidar_rejected.clear();
    kf->readout.velocity_B *= s;  // a rolling shutter's motion through the readout
    // An older scan's LiDAR pose holds the body's motion from the scan to the keyframe, whose
    // translation is a length (the rig's T_B_L for a scan at the keyframe or none: unchanged).
    if (kf->T_B_L.matrix() != T_B_L.matrix()) {
      const Mat3 R_motion = kf->T_B_L.linear() * T_B_L.linear().transpose();
      const Vec3 t_motion = kf->T_B_L.translation() - R_motion * T_B_L.translation();
      kf->T_B_L.translation() = R_motion * T_B_L.translation() + s * t_motion;
    }
  }
  for (auto& [id, lm] : map.landmarks) lm.rho[0] /= s;
  if (gauge.marginalization) gauge.marginalization = gauge.marginalization->mapped(moved);
  if (map.find(gauge.kf_id) != nullptr)  // a pose prior on a keyframe of the window moves too
    gauge.T_W_B.translation() = centre + s * (gauge.T_W_B.translation() - centre);
  // Frames placed against a keyframe of the window: their offset from it is a length too.
  for (FrameRecord& r : frames.open())
    if (r.ref_kf >= 0 && map.find(r.ref_kf) != nullptr) r.T_kf_B.translation() *= s;
  motion.last_T_W_B.translation() = centre + s * (motion.last_T_W_B.translation() - centre);
  motion.velocity_W *= s;
}

}  // namespace ovo::estimator
