// Which landmarks lie on the ground near the camera (they get the camera-height factor), from the
// plane each anchor keyframe's landmarks fit, and the camera height in the window's units that
// those planes agree on (a window started without a scale takes it). The online window and the
// offline refinement both label the ground this way.
#pragma once

#include <map>
#include <optional>
#include <unordered_map>
#include <vector>

#include "estimator/common/ground_plane.hpp"
#include "estimator/window/map.hpp"
#include "estimator/window/model.hpp"
#include "estimator/window/options.hpp"

namespace ovo::estimator {

/// Camera-height labels (DESIGN section 6): per anchor keyframe, the plane fitted to the landmarks
/// it anchors; its inliers near the camera get the factor when the plane agrees with the camera
/// height, and a labelled landmark keeps it while it stays within twice the inlier band. Returns
/// the planes' heights over the ground in the landmarks' units, gate or not (agreedGroundHeight).
std::vector<double> labelGroundLandmarks(std::unordered_map<TrackId, Landmark>& landmarks,
                                         const WindowModel& model, const WindowOptions& options,
                                         const GroundPlaneOptions& ground_options);

/// What one anchor keyframe's ground landmarks say of its camera-height correction: the mean of
/// their depths below the camera along their normals less the rig's camera height, m, and its
/// standard error over the landmarks.
struct AnchorGroundOffset {
  double mean_m = 0.0;
  double se_m = 0.0;
  int points = 0;
};

/// Per anchor keyframe with at least `min_points` ground landmarks (labelGroundLandmarks).
std::map<int, AnchorGroundOffset> anchorGroundOffsets(
    const std::unordered_map<TrackId, Landmark>& landmarks, const WindowModel& model,
    int min_points);

/// The standard deviation of the camera-height correction along the path that the anchors'
/// offsets show: their mean square about the rig's height less their mean squared standard error
/// and the square of `noise_floor_m` (what an anchor's offset errs by beyond its standard error),
/// so what the ground adds to the estimate's own noise; within [min_m, max_m]; min_m with fewer
/// than `min_anchors` anchors.
double pathHeightSigma(const std::map<int, AnchorGroundOffset>& offsets, int min_anchors,
                       double noise_floor_m, double min_m, double max_m);

/// The camera's height over the ground in the window's units, for a window whose scale is not
/// known (started at a unit baseline), from the anchor keyframes' plane heights
/// (labelGroundLandmarks): their upper median, when at least `min_keyframes` give a plane and more
/// than half of them lie within `agreement` (a fraction) of it; nullopt otherwise.
std::optional<double> agreedGroundHeight(std::vector<double> heights, int min_keyframes,
                                         double agreement);

}  // namespace ovo::estimator
