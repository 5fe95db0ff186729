// The window's uncertainty: the covariance of a keyframe's pose from the window's factors at their
// current states (what a consistency check, the NEES, weighs the pose error with).
#pragma once

#include <optional>
#include <vector>

#include "estimator/window/factors.hpp"

namespace ovo::estimator {

using Mat6 = Eigen::Matrix<double, 6, 6>;

/// The covariance of keyframe kf's pose as the factors give it at the current states: rows and
/// columns (rotation, position), the rotation as the rotation vector phi of a perturbation in the
/// world frame, R = Exp(phi) R_est, of the orientation the output uses (q_W_G when the model ties
/// the vision's rotations to the gyro chain, else q_W_B); the position in W, m. nullopt when Ceres
/// cannot compute it. A direction the factors leave unobserved gets no variance (a
/// pseudo-inverse), not an unbounded one; the window's gauge prior leaves none.
std::optional<Mat6> poseCovariance(std::vector<FactorSpec> factors,
                                   const std::vector<Keyframe*>& keyframes,
                                   const WindowModel& model, Keyframe& kf);

}  // namespace ovo::estimator
