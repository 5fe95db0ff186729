// Rescaling the window: when the LiDAR's ranges agree on another scale than the window's (e.g.
// after a headland turn with nothing in LiDAR range, where the gates then reject every range that
// would correct it), or when a window started without a scale gets one from its ground planes
// (WindowCore::rescaleToGround), every state that carries a length is scaled about the oldest
// keyframe, so that the trajectory before the window stays where it is.
#pragma once

#include "estimator/window/factors.hpp"
#include "estimator/window/frame_log.hpp"
#include "estimator/window/map.hpp"

namespace ovo::estimator {

/// What a rescale moves besides the window itself: the motion state of the last frame.
struct MotionState {
  SE3& last_T_W_B;   // the last frame's pose (the next prediction starts from it)
  Vec3& velocity_W;  // m/s
};

/// Scales positions by s about the oldest keyframe's: keyframe positions, terrain planes,
/// landmark inverse depths (by 1/s), the marginalisation prior and a pose prior on a keyframe of
/// the window, the frames recorded against the window's keyframes, the motion state, and the
/// body's motion in an older scan's LiDAR pose (Keyframe::T_B_L against the rig's T_B_L). Clears
/// the keyframes' rejected LiDAR associations (rejected at the wrong scale). Needs a keyframe.
void rescaleWindow(double s, WindowMap& map, WindowGauge& gauge, FrameLog& frames,
                   const MotionState& motion, const SE3& T_B_L);

}  // namespace ovo::estimator
