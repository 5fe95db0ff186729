// Alignment of an estimated trajectory onto a reference: Umeyama's closed form for SE(3) and
// Sim(3) (Umeyama, "Least-squares estimation of transformation parameters between two point
// patterns", PAMI 1991), as evo uses it.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "common/types.hpp"

namespace ovo::eval {

enum class AlignMode { kNone, kSE3, kSim3 };

/// "none", "se3", "sim3" (nullopt otherwise).
std::optional<AlignMode> parseAlignMode(const std::string& name);
std::string alignModeName(AlignMode mode);

/// A similarity p_ref = scale * R * p_est + t (scale = 1 for SE(3) and none).
struct Similarity {
  Mat3 R = Mat3::Identity();
  Vec3 t = Vec3::Zero();
  double scale = 1.0;

  Vec3 apply(const Vec3& p) const { return scale * (R * p) + t; }
  /// Applies it to a pose: rotation R * R_W_B, position apply(p).
  SE3 apply(const SE3& T) const;
};

/// Least-squares similarity mapping `from` onto `to` (Umeyama 1991, eqs. 34-43, with the
/// reflection guard S = diag(1, 1, -1) when det(U) det(V) < 0). nullopt with fewer than 3
/// points, different sizes or degenerate (collinear for rotation, all equal) points.
std::optional<Similarity> umeyama(const std::vector<Vec3>& from, const std::vector<Vec3>& to,
                                  bool with_scale);

/// Aligns the positions of `est` onto `ref` (same length, pose i with pose i).
/// kNone gives the identity.
std::optional<Similarity> alignTrajectories(const Trajectory& ref, const Trajectory& est,
                                            AlignMode mode);

/// The rigid transform that puts est's first pose onto ref's first pose (origin alignment,
/// what odometry drift is measured against). nullopt when either is empty.
std::optional<Similarity> alignFirstPose(const Trajectory& ref, const Trajectory& est);

/// est with the similarity applied to every pose.
Trajectory transformed(const Trajectory& est, const Similarity& S);

}  // namespace ovo::eval
