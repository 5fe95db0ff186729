// Which landmarks lie on the ground near the camera (they get the camera-height factor), from the
// plane each anchor keyframe's landmarks fit, and the camera height in the window's units that
// those planes agree on (a window started without a scale takes it). The online window and the
// offline refinement both label the ground this way.
#pragma once

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

/// The camera's height over the ground in the window's units, for a window whose scale is not
/// known (started at a unit baseline), from the anchor keyframes' plane heights
/// (labelGroundLandmarks): their upper median, when at least `min_keyframes` give a plane and more
/// than half of them lie within `agreement` (a fraction) of it; nullopt otherwise.
std::optional<double> agreedGroundHeight(std::vector<double> heights, int min_keyframes,
                                         double agreement);

}  // namespace ovo::estimator
