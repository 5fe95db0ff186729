// LiDAR-to-landmark association for the window (DESIGN section 6): scan end points go through
// T_C_L into the camera, are projected into the image, and each is paired with the nearest
// tracked observation within a pixel radius.
#pragma once

#include <optional>
#include <vector>

#include "camera/camera.hpp"
#include "estimator/window/map.hpp"

namespace ovo::estimator {

/// A beam end point seen by the camera.
struct BeamInImage {
  double range_m = 0.0;     // measured LiDAR range
  Vec3 p_C = Vec3::Zero();  // end point in the camera frame (m)
  Vec2 px = Vec2::Zero();   // its pixel
};

/// Valid beams of `scan` whose end points project inside the valid image. With
/// max_step_fraction > 0 only beams on a locally smooth surface: the `neighbours` beams on each
/// side are valid and each step between adjacent ranges stays below max_step_fraction * range
/// (a beam at a depth edge, e.g. through a canopy gap, lands next to features on the other side
/// of the edge and would bias the scale).
std::vector<BeamInImage> projectScan(const LidarScan& scan, const camera::Camera& camera,
                                     const SE3& T_C_L, double max_step_fraction = 0.0,
                                     int neighbours = 2);

/// Where azimuth phi_rad (any angle, taken modulo 2 pi) falls on the scan's beam grid: 0 at the
/// first beam, 1 at the second, whatever the sign of the increment; up to n for a scan that closes
/// the circle (between its last and its first beam), else up to n - 1; nullopt outside the scan.
std::optional<double> scanGridPosition(const LidarScan& scan, double phi_rad);

/// The scan's range at azimuth phi_rad in the L x-y plane, interpolated between the two beams
/// around it (scanGridPosition), when both and `neighbours` more on each side are valid and
/// adjacent ranges differ by less than max_step_fraction of the range (a smooth surface); nullopt
/// otherwise.
std::optional<double> interpolateRange(const LidarScan& scan, double phi_rad,
                                       double max_step_fraction, int neighbours);

/// The scan-plane (x-y) distance of the point where the ray c_L + s b_L (s > 0) meets the plane
/// through hit_L with normal up_L: the range to compare with a landmark seen along b_L near a beam
/// that ends on the ground (isGroundBeam). A pitched LiDAR meets the ground at a grazing angle,
/// so the beam's own range is far off for a point a fraction of a degree off the scan plane.
/// nullopt when the ray does not go down to the plane (b_L . up_L > -0.02).
std::optional<double> groundRangeAlongRay(const Vec3& hit_L, const Vec3& up_L, const Vec3& c_L,
                                          const Vec3& b_L);

/// The sine of the angle at which the beam from the LiDAR to hit_L meets the plane with unit
/// normal up_L: the fraction of the beam's range noise that moves its end point off that plane
/// (small for a pitched LiDAR's grazing ground beams, so the plane's height is known far better
/// than the range). 0 for hit_L at the origin.
double groundIncidenceSine(const Vec3& hit_L, const Vec3& up_L);

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
