// The window's LiDAR ranges to its landmarks: beams near tracks (the candidates a keyframe keeps),
// the ranges each keyframe's scan measures to the landmarks it sees, their association with the
// landmarks (gated by depth), and the scale the ranges agree on (for a rescale).
#pragma once

#include <optional>
#include <vector>

#include "estimator/estimator.hpp"
#include "estimator/window/lidar_association.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"
#include "estimator/window/scans.hpp"

namespace ovo::estimator {

/// A range of a keyframe's scan to a landmark it sees, and the landmark's distance as the window
/// has it (both in the scan plane for interpolated ranges).
struct LidarRange {
  LidarAssociation association;
  double landmark_m = 0.0;  // the landmark's distance from the LiDAR now
  double measured_m = 0.0;  // the range it must agree with (ground beams: along the ray)
  bool ground = false;      // a beam ending on the ground (GroundBeams::kPlane)
};

class WindowLidar {
 public:
  WindowLidar(const SensorSetup& setup, const WindowOptions& options)
      : setup_(setup), options_(options) {}

  /// The scan's beams on smooth surfaces, in the image (to pair with features by their pixel).
  std::vector<BeamInImage> usableBeams(const FrameScan& scan) const;
  /// Beams paired with the observations (nearest within lidar_radius_px); none without a scan.
  std::vector<LidarAssociation> candidates(const std::vector<TrackObservation>& observations,
                                           const std::optional<FrameScan>& scan) const;
  /// Every range the keyframe's scan measures to a landmark the window has for a track it sees.
  std::vector<LidarRange> rangesAt(const Keyframe& kf, const WindowMap& map) const;
  /// Pairs the keyframe's landmarks with its scan's ranges (gate_depth: only those within
  /// lidar_depth_gate of the landmark's distance), except those paired or rejected before.
  void associate(Keyframe& kf, const WindowMap& map, bool gate_depth) const;
  /// The window's landmark distances over the LiDAR's ranges to them, when enough ranges from
  /// enough landmarks agree on one ratio (lidar_rescale_*); nullopt otherwise.
  std::optional<double> scaleRatio(const WindowMap& map) const;

 private:
  const SensorSetup& setup_;
  const WindowOptions& options_;
};

}  // namespace ovo::estimator
