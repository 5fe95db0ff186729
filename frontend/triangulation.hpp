// Two-view triangulation of bearing pairs (midpoint of the closest points of the two rays).
// Depths are signed distances along each bearing, never z: fisheye bearings may have z <= 0.
#pragma once

#include <optional>

#include "common/types.hpp"

namespace ovo::frontend {

/// A point triangulated from two bearings, with its signed depth along each bearing.
struct TwoViewPoint {
  Vec3 p_prev = Vec3::Zero();  // midpoint, previous camera frame
  double depth_prev = 0.0;     // p ~ depth_prev * bearing_prev (negative: behind the ray)
  double depth_cur = 0.0;      // R_cur_prev p + t_cur_prev ~ depth_cur * bearing_cur
};

/// Midpoint triangulation for X_cur = R_cur_prev X_prev + t_cur_prev. Minimises
/// |depth_prev R b_prev + t - depth_cur b_cur|; nullopt when the rotated rays are parallel to
/// within min_angle_rad (no parallax: depth undefined) or the input is not finite.
std::optional<TwoViewPoint> triangulateMidpoint(const Mat3& R_cur_prev, const Vec3& t_cur_prev,
                                                const Vec3& bearing_prev, const Vec3& bearing_cur,
                                                double min_angle_rad = 1e-9);

}  // namespace ovo::frontend
