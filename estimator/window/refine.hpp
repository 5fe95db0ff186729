// The offline full refinement (`--refine full`, DESIGN section 7): every keyframe of the run in one
// batch, with landmarks rebuilt from the tracks in pieces of bounded span, robust re-weighting and
// outlier removal between passes.
#pragma once

#include <optional>
#include <string>
#include <unordered_map>
#include <vector>

#include "estimator/common/ground_plane.hpp"
#include "estimator/estimator.hpp"
#include "estimator/window/ground_labels.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/options.hpp"
#include "estimator/window/solve.hpp"

namespace ovo::estimator {

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
/// at its value). With a gravity block (WindowMap::gravity, set, and usesAccel(model)) the
/// accelerometer's factors join the batch from a copy of it. Writes the poses and biases back
/// only when usable.
RefineInfo refineKeyframes(const std::vector<Keyframe*>& keyframes,
                           const std::unordered_map<TrackId, Vec3>& points_W,
                           const WindowModel& model, const std::vector<WindowGauge>& segment_gauges,
                           const WindowOptions& options, const GroundPlaneOptions& ground_options,
                           const double* time_offset_s = nullptr,
                           const double* gravity = nullptr);

}  // namespace ovo::estimator
