// The window's LiDAR ranges to its landmarks: beams near tracks (the candidates a keyframe keeps),
// the ranges each keyframe's scan measures to the landmarks it sees, their association with the
// landmarks (gated by depth), the scale the ranges agree on (for a rescale), and the vote on the
// start's scale from range ratios.
#pragma once

#include <optional>
#include <unordered_map>
#include <utility>
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
  /// Every range the keyframe's scan measures to a landmark the window has for a track it sees;
  /// with scale != 1, as if the window were scaled by it (each point scaled about the keyframe's
  /// camera, LidarRange::landmark_m at that scale).
  /// points_W: the landmarks' world points (WindowMap::pointW) when known already.
  using PointsW = std::unordered_map<TrackId, Vec3>;
  std::vector<LidarRange> rangesAt(const Keyframe& kf, const WindowMap& map, double scale = 1.0,
                                   const PointsW* points_W = nullptr) const;
  /// Pairs the keyframe's landmarks with its scan's ranges (gate_depth: only those within
  /// lidar_depth_gate of the landmark's distance), except those paired or rejected before.
  void associate(Keyframe& kf, const WindowMap& map, bool gate_depth) const;
  /// The window's landmark distances over the LiDAR's ranges to them, when enough ranges from
  /// enough landmarks agree on one ratio (lidar_rescale_*); else, with interpolated ranges, the
  /// ratio of the scale between 0.25 and 4 at which the scan agrees with the map when it agrees
  /// there clearly better than at the window's own (a wrong scale makes the ranges disagree
  /// among themselves, not agree on another ratio); nullopt otherwise.
  /// searched (optional): set to whether the ratio came from the search rather than from ranges
  /// that agree at the window's own scale.
  std::optional<double> scaleRatio(const WindowMap& map, bool* searched = nullptr) const;

 private:
  /// The window's non-ground ranges' landmark distance over range, with their tracks, at scale.
  std::vector<std::pair<double, TrackId>> rangeRatios(const WindowMap& map, double scale,
                                                      const PointsW* points_W = nullptr) const;
  /// The median of the ratios when at least lidar_rescale_min_ranges of them, half of them and
  /// three landmarks agree with it within lidar_rescale_agreement.
  std::optional<double> agreedRatio(const std::vector<std::pair<double, TrackId>>& ratios) const;

  const SensorSetup& setup_;
  const WindowOptions& options_;
};

/// The initialisation's metric scale from LiDAR range ratios (beam range over the unit-baseline
/// distance of the track it lands next to). Ratios are grouped by agreement within 20 %: the
/// largest group wins unless a group at least half its size disagrees with it (beams through a
/// canopy gap onto the next row give a consistent wrong ratio), or the ground plane's scale
/// disagrees with it (beams that pass under a canopy's lower edge land next to the canopy's
/// features and agree with each other on a ratio several times too large; with a narrow camera
/// they can outnumber the beams on the ground). The ground plane settles such a tie with the
/// largest group it agrees with, of at least half the largest's size or min_associations / 2;
/// otherwise the tie is put off while allowed, then the ground plane's own scale is taken when
/// there is one (the LiDAR is overruled), else the nearest surfaces (smallest ratio: a gap only
/// reads too far).
struct LidarScaleVote {
  enum class Outcome {
    kAgreed,         // the largest group, unchallenged
    kGroundSettled,  // a tie settled by the ground plane
    kPutOff,         // a tie: wait for a later frame
    kForced,         // a tie that could not wait, without a ground plane: the nearest surfaces
    kOverruled,      // a tie that could not wait, no group agreeing with the ground plane: no
                     // LiDAR scale, the ground plane's is to be used
    kTooFew,         // too few ratios, or no group big enough: no LiDAR scale
  };
  Outcome outcome = Outcome::kTooFew;
  std::optional<double> scale;  // the chosen group's median ratio (kAgreed, kGroundSettled,
                                // kForced)
};
LidarScaleVote voteLidarScale(std::vector<double> ratios, std::optional<double> ground_scale,
                              int min_associations, bool can_put_off);

}  // namespace ovo::estimator
