// The simulated robot's exact motion: a uniform cubic B-spline (C2: continuous acceleration and
// angular acceleration) over position in the terrain plane, heading and ride vibration, planned
// from a smoothed speed / yaw-rate schedule of a row-following unicycle (rows, headland U-turns,
// in-place turns, stops). Poses, velocities, accelerations and body rates are analytic derivatives
// of the spline: the gyro reads omega_B exactly, never a finite difference of poses. On uneven
// ground (a height field on the terrain plane) the body rides on the local ground: the point
// below it is lifted by the field and the body is tilted from the plane's normal to the local
// one, with the field's analytic derivatives carried into the velocity, acceleration and rates.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

#include "common/types.hpp"
#include "sim/scenario.hpp"

namespace ovo::sim {

class VineyardWorld;
class HeightField;

/// Uniform cubic B-spline in R^6 with knot spacing dt_s; segment i, t in [i dt, (i+1) dt], blends
/// control points i..i+3 (de Boor / Qin, "General matrix representations for B-splines", 1998).
class UniformCubicBSpline {
 public:
  using Vec6 = Eigen::Matrix<double, 6, 1>;
  UniformCubicBSpline() = default;
  UniformCubicBSpline(double dt_s, std::vector<Vec6> control_points);
  /// Value and derivatives (per second) at t, clamped to [0, endTime()].
  void evaluate(double t_s, Vec6* value, Vec6* d1 = nullptr, Vec6* d2 = nullptr) const;
  double endTime() const;
  double knotSpacing() const { return dt_; }

 private:
  double dt_ = 0.05;
  std::vector<Vec6> points_;
};

/// Kinematic state of the body B in the world W at one time.
struct BodyState {
  SE3 T_W_B = SE3::Identity();
  Vec3 v_W = Vec3::Zero();      // velocity of B's origin in W (m/s)
  Vec3 a_W = Vec3::Zero();      // acceleration of B's origin in W (m/s^2)
  Vec3 omega_B = Vec3::Zero();  // angular velocity of B relative to W, in B (rad/s)
};

/// The body's motion. Channels: terrain-plane position (a, b) in frame T, bump height along the
/// terrain normal, heading psi about the normal, vibration pitch theta and roll phi;
/// R_W_B = R_W_T Rz(psi) Ry(theta) Rx(phi), p_W = R_W_T (a, b, body_height + bump).
/// With a height field h(x, y) (world x, y; added to the plane's height): the ground point is
/// g = R_W_T (a, b, 0) + h e_z, its unit normal n = (-dz/dx, -dz/dy, 1) / norm, and
/// R_W_B = R_tilt(n_plane -> n) R_W_T Rz Ry Rx, p_W = g + n (body_height + bump), R_tilt being
/// the smallest rotation taking the plane's normal onto n.
class BodyTrajectory {
 public:
  BodyTrajectory() = default;
  BodyTrajectory(const Mat3& R_W_T, double body_height_m, UniformCubicBSpline spline);
  /// On uneven ground: `field` added to the plane whose slope is `plane_gradient` (dz/dx, dz/dy).
  BodyTrajectory(const Mat3& R_W_T, double body_height_m, UniformCubicBSpline spline,
                 std::shared_ptr<const HeightField> field, const Vec2& plane_gradient);

  BodyState state(double t_s) const;
  /// The ground point below the body at t_s and the ground's unit normal there.
  void groundContact(double t_s, Vec3* point_W, Vec3* normal_W) const;
  SE3 T_W_B(double t_s) const { return state(t_s).T_W_B; }
  /// Length of the motion (s); times are seconds from the sequence start.
  double duration() const { return spline_.endTime(); }

 private:
  BodyState roughState(double t_s) const;

  Mat3 R_W_T_ = Mat3::Identity();
  double body_height_m_ = 0.0;
  UniformCubicBSpline spline_;
  std::shared_ptr<const HeightField> field_;  // null: the plane
  Vec2 plane_gradient_ = Vec2::Zero();
};

/// Plans the motion of `options` in `world`, lasting at least `min_duration_s` (held still at the
/// end if the plan is shorter). The seed perturbs speeds, start offset and vibration.
BodyTrajectory planTrajectory(const TrajectoryOptions& options, const VineyardWorld& world,
                              std::uint64_t seed, double min_duration_s = 0.0);

}  // namespace ovo::sim
