// One sighting of a landmark as the window weighs it: its noise (pixel noise and the track's
// creep since the anchor), its square-root information in the bearing factor's axes, and where
// the camera was in the body when the sighting's image row was exposed (rolling shutter), and the
// sightings' errors against their landmarks at the current states (the outlier test's metric).
#pragma once

#include <unordered_map>
#include <vector>

#include "common/types.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/model.hpp"

namespace ovo::estimator {

/// A sighting's noise (px) against one `frames` earlier on the same track: white_px2 (px^2) of the
/// sightings' own noise and the track's creep in between, which random-walks.
double sightingSigmaPx(double white_px2, double frames, const WindowModel& model);
/// The noise (px) of a sighting o against its landmark's anchor keyframe (pixel noise and creep).
double anchorSigmaPx(const Keyframe& anchor, const TrackObservation& o, const WindowModel& model);
/// The square-root information of a sighting with noise sigma_px in
/// factors::BearingFactor::tangentBasis(o.bearing_C)'s axes: the camera's pixels per radian there
/// over sigma_px (bearing_sigma_from_camera and known), else focal_px / sigma_px.
Mat2 sightingSqrtInformation(const TrackObservation& o, double sigma_px, const WindowModel& model);

/// The camera's pose in the body of keyframe kf when it took sighting o (Keyframe::cameraAt at
/// o's row).
SE3 sightingExtrinsics(const Keyframe& kf, const TrackObservation& o, const WindowModel& model);
/// The camera of a landmark's anchor sighting in its anchor keyframe's body.
SE3 anchorExtrinsics(const Keyframe& anchor, const Landmark& lm, const WindowModel& model);

/// Angular error (rad) of every bearing observation at the current states, by (kf id, track).
struct ObservationError {
  int kf_id;
  TrackId track;
  double angle_rad;  // between the sighting and the landmark's predicted bearing
  double sigmas;     // the same in the sighting's own sigmas against its anchor (inf: behind)
};
std::vector<ObservationError> observationErrors(const std::vector<Keyframe*>& keyframes,
                                                const std::unordered_map<TrackId, Landmark>& lms,
                                                const WindowModel& model);

}  // namespace ovo::estimator
