// LiDAR-to-landmark association for the window (DESIGN section 6): scan end points go through
// T_C_L into the camera, are projected into the image, and each is paired with the nearest
// tracked observation within a pixel radius.
#pragma once

#include <vector>

#include "camera/camera.hpp"
#include "estimator/window_map.hpp"

namespace ovo::estimator {

/// A beam end point seen by the camera.
struct BeamInImage {
  double range_m = 0.0;     // measured LiDAR range
  Vec3 p_C = Vec3::Zero();  // end point in the camera frame (m)
  Vec2 px = Vec2::Zero();   // its pixel
};

/// Valid beams of `scan` whose end points project inside the valid image.
std::vector<BeamInImage> projectScan(const LidarScan& scan, const camera::Camera& camera,
                                     const SE3& T_C_L);

/// A beam paired with an observation (nearest within radius_px; each track used once, by its
/// nearest beam).
struct BeamMatch {
  TrackId track_id = 0;
  double range_m = 0.0;            // LiDAR range (m)
  double beam_dist_C = 0.0;        // distance of the beam end point from the camera centre (m)
  Vec3 bearing_C = Vec3::UnitZ();  // the observation's bearing
};
std::vector<BeamMatch> associateBeams(const std::vector<BeamInImage>& beams,
                                      const std::vector<TrackObservation>& observations,
                                      double radius_px);

}  // namespace ovo::estimator
