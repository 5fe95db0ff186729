// The offline full refinement (`--refine full`, DESIGN section 7): every keyframe of the run in one
// batch, with landmarks rebuilt from the tracks in pieces of bounded span, robust re-weighting and
// outlier removal between passes; plus the ground labelling it shares with the online window.
#pragma once

#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/ground_plane.hpp"
#include "estimator/window_map.hpp"
#include "estimator/window_options.hpp"
#include "estimator/window_problem.hpp"

namespace ovo::estimator {

/// What the last full refinement did (diagnostics; the run's notes summarise it).
struct RefineInfo {
  int keyframes = 0;
  int landmarks = 0;         // landmark pieces with factors
  int bearing_factors = 0;   // in the last pass
  int lidar_factors = 0;     // in the last pass
  int ground_factors = 0;    // in the last pass
  int removed_outliers = 0;  // bearing observations and LiDAR associations, all passes
  int passes = 0;
  int iterations = 0;         // all passes
  double initial_cost = 0.0;  // first pass
  double final_cost = 0.0;    // last pass
  bool usable = false;        // every pass gave finite states (else the online poses are kept)
  std::string message;        // the last pass's solver message
};

/// Camera-height labels (DESIGN section 6): per anchor keyframe, the plane fitted to the landmarks
/// it anchors; its inliers near the camera get the factor when the plane agrees with the camera
/// height, and a labelled landmark keeps it while it stays within twice the inlier band.
void labelGroundLandmarks(std::unordered_map<TrackId, Landmark>& landmarks,
                          const WindowModel& model, const WindowOptions& options,
                          const GroundPlaneOptions& ground_options);

/// Re-optimises `keyframes` (time order, their current poses as the initial values) with every
/// factor the run gathered. A track's sightings become landmarks of at most
/// options.refine_max_span_kf keyframes each (tracks creep, a long span ties far keyframes with a
/// biased ray), initialised by triangulation at the current poses (else from `points_W`, the last
/// window estimate). `segment_gauges` are the gauges each segment started with: the first
/// keyframe's holds the run's gauge; the first keyframe of each later segment keeps its pose with
/// a looser prior (only the gyro links segments) and its bias prior. Without a gauge for the
/// first keyframe it is held at its pose with the model's bias prior. Writes the poses and biases
/// back only when usable.
RefineInfo refineKeyframes(const std::vector<Keyframe*>& keyframes,
                           const std::unordered_map<TrackId, Vec3>& points_W,
                           const WindowModel& model, const std::vector<WindowGauge>& segment_gauges,
                           const WindowOptions& options, const GroundPlaneOptions& ground_options);

}  // namespace ovo::estimator
