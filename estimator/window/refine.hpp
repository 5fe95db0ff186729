// The offline full refinement (`--refine full`, DESIGN section 7): every keyframe of the run in one
// batch, with landmarks rebuilt from the tracks in pieces of bounded span, robust re-weighting and
// outlier removal between passes; plus the ground labelling it shares with the online window.
#pragma once

#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/estimator.hpp"
#include "estimator/common/ground_plane.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"
#include "estimator/window/solve.hpp"

namespace ovo::estimator {

/// Camera-height labels (DESIGN section 6): per anchor keyframe, the plane fitted to the landmarks
/// it anchors; its inliers near the camera get the factor when the plane agrees with the camera
/// height, and a labelled landmark keeps it while it stays within twice the inlier band. Returns
/// the planes' heights over the ground in the landmarks' units, gate or not (agreedGroundHeight).
std::vector<double> labelGroundLandmarks(std::unordered_map<TrackId, Landmark>& landmarks,
                                         const WindowModel& model, const WindowOptions& options,
                                         const GroundPlaneOptions& ground_options);

/// The camera's height over the ground in the window's units, for a window whose scale is not
/// known (started at a unit baseline), from the anchor keyframes' plane heights
/// (labelGroundLandmarks): their upper median, when at least `min_keyframes` give a plane and more
/// than half of them lie within `agreement` (a fraction) of it; nullopt otherwise.
std::optional<double> agreedGroundHeight(std::vector<double> heights, int min_keyframes,
                                         double agreement);

/// Re-optimises `keyframes` (time order, their current poses as the initial values) with every
/// factor the run gathered. A track's sightings become landmarks spanning at most
/// options.refine_max_span_frames frames each (tracks creep: with anchor factors a long span ties
/// far keyframes with a biased ray; bearing steps, options.refine_bearing_steps whatever the
/// online window used, model the creep and keep one per track),
/// initialised by triangulation at the current poses (else from `points_W`, the last
/// window estimate). `segment_gauges` are the gauges each segment started with: the first
/// keyframe's holds the run's gauge; the first keyframe of each later segment keeps its pose with
/// a looser prior (only the gyro links segments) and its bias prior. Without a gauge for the
/// first keyframe it is held at its pose with the model's bias prior. With a time_offset_s block
/// (the window's, estimatesTimeOffset(model)) the gyro factors shift their intervals to it (held
/// at its value). Writes the poses and biases back only when usable.
RefineInfo refineKeyframes(const std::vector<Keyframe*>& keyframes,
                           const std::unordered_map<TrackId, Vec3>& points_W,
                           const WindowModel& model, const std::vector<WindowGauge>& segment_gauges,
                           const WindowOptions& options, const GroundPlaneOptions& ground_options,
                           const double* time_offset_s = nullptr);

}  // namespace ovo::estimator
