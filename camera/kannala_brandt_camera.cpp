#include "camera/kannala_brandt_camera.hpp"

#include <cmath>
#include <numbers>

#include "common/error.hpp"

namespace ovo::camera {

KannalaBrandtCamera::KannalaBrandtCamera(const KannalaBrandtParams& params) : params_(params) {
  if (!(params_.fx > 0.0 && params_.fy > 0.0))
    fail("Kannala-Brandt camera: fx and fy must be positive, got {} {}", params_.fx, params_.fy);
  if (params_.width <= 0 || params_.height <= 0)
    fail("Kannala-Brandt camera: image size must be positive, got {}x{}", params_.width,
         params_.height);
  for (double v : {params_.cx, params_.cy, params_.k1, params_.k2, params_.k3, params_.k4})
    if (!std::isfinite(v)) fail("Kannala-Brandt camera: a parameter is not finite");
  // The model is usable while theta_d(theta) increases.
  constexpr double kStep = 1e-3;
  double theta = 0.0;
  while (theta + kStep <= std::numbers::pi && distortDeriv(theta + kStep) > 0.0) theta += kStep;
  theta_max_rad_ = theta;
  theta_d_max_ = distort(theta_max_rad_);
}

double KannalaBrandtCamera::distort(double theta) const {
  const auto& p = params_;
  const double t2 = theta * theta;
  return theta * (1.0 + t2 * (p.k1 + t2 * (p.k2 + t2 * (p.k3 + t2 * p.k4))));
}

double KannalaBrandtCamera::distortDeriv(double theta) const {
  const auto& p = params_;
  const double t2 = theta * theta;
  return 1.0 + t2 * (3.0 * p.k1 + t2 * (5.0 * p.k2 + t2 * (7.0 * p.k3 + t2 * 9.0 * p.k4)));
}

std::optional<Vec2> KannalaBrandtCamera::project(const Vec3& p_C,
                                                 Eigen::Matrix<double, 2, 3>* d_px_d_p) const {
  const auto& p = params_;
  const double x = p_C.x(), y = p_C.y(), z = p_C.z();
  const double r = std::hypot(x, y);
  const double n2 = r * r + z * z;
  if (!(n2 > 0.0)) return std::nullopt;
  const double theta = std::atan2(r, z);
  if (theta > theta_max_rad_) return std::nullopt;
  const Eigen::Matrix2d F = Eigen::Vector2d(p.fx, p.fy).asDiagonal();
  const Vec2 centre(p.cx, p.cy);
  if (r < 1e-12 * std::sqrt(n2)) {  // on the optical axis: theta_d ~ theta ~ r / z
    if (d_px_d_p) {
      d_px_d_p->setZero();
      d_px_d_p->leftCols<2>() = F / z;
    }
    return centre;
  }
  const double theta_d = distort(theta);
  const double g = theta_d / r;
  if (d_px_d_p) {
    const Eigen::RowVector3d d_r(x / r, y / r, 0.0);
    const Eigen::RowVector3d d_theta = Eigen::RowVector3d(z * x / r, z * y / r, -r) / n2;
    const Eigen::RowVector3d d_g = distortDeriv(theta) * d_theta / r - theta_d / (r * r) * d_r;
    Eigen::Matrix<double, 2, 3> d_w = Vec2(x, y) * d_g;
    d_w(0, 0) += g;
    d_w(1, 1) += g;
    *d_px_d_p = F * d_w;
  }
  return Vec2(F * Vec2(g * x, g * y) + centre);
}

std::optional<Vec3> KannalaBrandtCamera::unproject(const Vec2& px) const {
  const auto& p = params_;
  const Vec2 m((px.x() - p.cx) / p.fx, (px.y() - p.cy) / p.fy);
  const double theta_d = m.norm();
  if (!(theta_d <= theta_d_max_)) return std::nullopt;
  if (theta_d < 1e-12) return Vec3(0.0, 0.0, 1.0);
  // Newton on theta_d(theta) = theta_d, monotonic on [0, theta_max].
  double theta = std::min(theta_d, theta_max_rad_);
  for (int i = 0; i < 30; ++i) {
    const double f = distort(theta) - theta_d;
    if (std::abs(f) < 1e-14) break;
    theta = std::clamp(theta - f / distortDeriv(theta), 0.0, theta_max_rad_);
  }
  if (!(std::abs(distort(theta) - theta_d) < 1e-9)) return std::nullopt;
  const double s = std::sin(theta) / theta_d;
  return Vec3(s * m.x(), s * m.y(), std::cos(theta));
}

bool KannalaBrandtCamera::isValid(const Vec2& px) const {
  if (!(px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= params_.width - 1 &&
        px.y() <= params_.height - 1))
    return false;
  return unproject(px).has_value();
}

}  // namespace ovo::camera
