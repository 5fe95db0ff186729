// A sighting's noise, its camera pose at its row's time, and its error after a solve.
#include "estimator/window/sighting.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "common/so3.hpp"
#include "factors/bearing_factor.hpp"

namespace ovo::estimator {

double anchorSigmaPx(const Keyframe& anchor, const TrackObservation& o, const WindowModel& model) {
  const auto a = anchor.observations.find(o.track_id);
  const int frames = a == anchor.observations.end() ? 0 : std::max(0, o.age - a->second.age);
  return sightingSigmaPx(model.pixel_sigma_px * model.pixel_sigma_px, frames, model);
}

double sightingSigmaPx(double white_px2, double frames, const WindowModel& model) {
  return std::sqrt(white_px2 + model.track_creep_px * model.track_creep_px * frames);
}

Mat2 sightingSqrtInformation(const TrackObservation& o, double sigma_px, const WindowModel& model) {
  if (model.bearing_sigma_from_camera && !o.px_per_rad.isZero()) return o.px_per_rad / sigma_px;
  return Mat2::Identity() * (model.focal_px / sigma_px);
}

SE3 sightingExtrinsics(const Keyframe& kf, const TrackObservation& o, const WindowModel& model) {
  return kf.cameraAt(o, model.T_B_C);
}

SE3 anchorExtrinsics(const Keyframe& anchor, const Landmark& lm, const WindowModel& model) {
  return anchor.cameraAt(lm.anchor_row_s, model.T_B_C);
}

std::vector<ObservationError> observationErrors(const std::vector<Keyframe*>& keyframes,
                                                const std::unordered_map<TrackId, Landmark>& lms,
                                                const WindowModel& model) {
  std::vector<ObservationError> out;
  const auto kf_of = keyframesById(keyframes);
  for (const auto& [id, lm] : lms) {
    auto a = kf_of.find(lm.anchor_kf);
    if (a == kf_of.end() || !(lm.rho[0] >= 0.0)) continue;
    const Keyframe& anchor = *a->second;
    const SE3 T_B_Ca = anchorExtrinsics(anchor, lm, model);
    for (const Keyframe* kf : keyframes) {
      if (kf == &anchor) continue;
      auto obs = kf->observations.find(id);
      if (obs == kf->observations.end()) continue;
      const TrackObservation& o = obs->second;
      const auto u = factors::predictBearing(lm.bearing_anchor_C, T_B_Ca,
                                             sightingExtrinsics(*kf, o, model), anchor.q_W_B,
                                             anchor.p_W_B, kf->q_W_B, kf->p_W_B, lm.rho[0], false);
      if (!u) {
        out.push_back({kf->id, id, M_PI, std::numeric_limits<double>::infinity()});
        continue;
      }
      // atan2, not acos of the dot product: acos cannot resolve an angle below sqrt(eps)
      // (1.5e-8 rad), so one rounding of the dot product made an exact sighting read that.
      const double angle = std::atan2(u->u.cross(o.bearing_C).norm(), u->u.dot(o.bearing_C));
      // In the sighting's own sigmas: its tangent-plane offset whitened as its factor would be
      // against the anchor (pixel noise and creep since the anchor, through the camera).
      const Mat2 W = sightingSqrtInformation(o, anchorSigmaPx(anchor, o, model), model);
      const Vec2 r = W * (factors::BearingFactor::tangentBasis(o.bearing_C) * u->u);
      const double sigmas = u->u.dot(o.bearing_C) > 0.0
                                ? r.norm()
                                : std::numeric_limits<double>::infinity();  // behind
      out.push_back({kf->id, id, angle, sigmas});
    }
  }
  return out;
}

}  // namespace ovo::estimator
