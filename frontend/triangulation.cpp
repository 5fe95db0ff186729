#include "frontend/triangulation.hpp"

#include <cmath>

namespace ovo::frontend {

std::optional<TwoViewPoint> triangulateMidpoint(const Mat3& R_cur_prev, const Vec3& t_cur_prev,
                                                const Vec3& bearing_prev, const Vec3& bearing_cur,
                                                double min_angle_rad) {
  // Normal equations of min |l_p a - l_c c + t| with a = R b_p, c = b_c (unit):
  //   l_p - beta l_c = -a.t,  beta l_p - l_c = -c.t,  beta = a.c.
  const Vec3 a = (R_cur_prev * bearing_prev).normalized();
  const Vec3 c = bearing_cur.normalized();
  const double sin_angle = a.cross(c).norm();
  if (!(sin_angle > std::sin(min_angle_rad)) || !t_cur_prev.allFinite()) return std::nullopt;
  const double beta = a.dot(c);
  const double det = 1.0 - beta * beta;  // = sin^2 of the ray angle
  const double at = a.dot(t_cur_prev), ct = c.dot(t_cur_prev);
  TwoViewPoint out;
  out.depth_prev = (beta * ct - at) / det;
  out.depth_cur = beta * out.depth_prev + ct;
  // Scale back to the caller's bearing lengths (normally 1).
  const double np = bearing_prev.norm(), nc = bearing_cur.norm();
  const Vec3 on_prev_ray_P = out.depth_prev * (bearing_prev / np);
  const Vec3 on_cur_ray_P = R_cur_prev.transpose() * (out.depth_cur * c - t_cur_prev);
  out.p_prev = 0.5 * (on_prev_ray_P + on_cur_ray_P);
  out.depth_prev /= np;
  out.depth_cur /= nc;
  if (!out.p_prev.allFinite()) return std::nullopt;
  return out;
}

}  // namespace ovo::frontend
