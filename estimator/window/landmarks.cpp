// New landmarks from a keyframe's tracks, and the outliers removed after a solve.
#include "estimator/window/landmarks.hpp"

#include <cmath>
#include <vector>

#include "estimator/window/lidar_gate.hpp"
#include "estimator/window/sighting.hpp"
#include "frontend/triangulation.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

}  // namespace

void triangulateNewLandmarks(WindowMap& map, const Keyframe& kf, const SE3& T_B_C,
                             const WindowOptions& options) {
  const double cos_min = std::cos(options.landmark_min_parallax_deg * kDegToRad);
  for (const auto& [id, o] : kf.observations) {
    if (map.landmarks.count(id)) continue;
    const Keyframe* anchor = nullptr;
    for (const auto& other : map.keyframes) {
      if (other.get() == &kf) break;
      if (other->observations.count(id)) {
        anchor = other.get();
        break;
      }
    }
    if (anchor == nullptr) continue;
    const TrackObservation& oa = anchor->observations.at(id);
    const Vec3& b_a = oa.bearing_C;
    // Both cameras at their sightings' rows (a rolling shutter).
    const SE3 T_Cn_Ca =
        (kf.pose() * kf.cameraAt(o, T_B_C)).inverse() * anchor->pose() * anchor->cameraAt(oa, T_B_C);
    if ((T_Cn_Ca.linear() * b_a).dot(o.bearing_C) > cos_min) continue;
    const auto p =
        frontend::triangulateMidpoint(T_Cn_Ca.linear(), T_Cn_Ca.translation(), b_a, o.bearing_C);
    if (!p || p->depth_prev < options.landmark_min_depth_m || p->depth_cur <= 0.0) continue;
    Landmark lm;
    lm.id = id;
    lm.anchor_kf = anchor->id;
    lm.bearing_anchor_C = b_a;
    lm.anchor_row_s = oa.row_s;
    // Far triangulations are poor: such a landmark starts at infinity (its rotation information
    // counts at once, the solve may bring it nearer).
    lm.rho[0] = p->depth_prev > options.landmark_max_depth_m ? 0.0 : 1.0 / p->depth_prev;
    map.landmarks[id] = lm;
  }
}

void removeOutliers(WindowMap& map, const WindowModel& model, const WindowOptions& options) {
  std::vector<Keyframe*> kfs;
  for (auto& kf : map.keyframes) kfs.push_back(kf.get());
  for (const ObservationError& err : observationErrors(kfs, map.landmarks, model)) {
    if (err.sigmas <= options.outlier_sigmas) continue;
    if (Keyframe* kf = map.find(err.kf_id)) kf->observations.erase(err.track);
  }
  // Landmarks at the near bound are removed; far ones, at infinity included, stay.
  for (auto it = map.landmarks.begin(); it != map.landmarks.end();) {
    const Landmark& lm = it->second;
    const Keyframe* anchor = map.find(lm.anchor_kf);
    const bool bad = anchor == nullptr || !anchor->observations.count(it->first) ||
                     !(lm.rho[0] >= 0.0) || lm.rho[0] >= model.max_rho * 0.9999;
    it = bad ? map.landmarks.erase(it) : std::next(it);
  }
  // LiDAR associations that disagree with the solved landmark by more than the gate.
  for (Keyframe* kf : kfs) {
    std::erase_if(kf->lidar, [&](const LidarAssociation& a) {
      auto lm = map.landmarks.find(a.track_id);
      if (lm == map.landmarks.end()) return true;
      const auto p_W = map.pointW(lm->second, model.T_B_C);
      const bool outlier = !p_W || lidarOutlier(a, *p_W, *kf, model, options.lidar_outlier_sigmas,
                                                options.lidar_outlier_fraction);
      if (outlier) kf->lidar_rejected.insert(a.track_id);
      return outlier;
    });
  }
}

}  // namespace ovo::estimator
