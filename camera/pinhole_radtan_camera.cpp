#include "camera/pinhole_radtan_camera.hpp"

#include <Eigen/Dense>
#include <cmath>
#include <limits>

#include "common/error.hpp"

namespace ovo::camera {
namespace {
// Largest normalised radius searched for the fold-over of the radial distortion (84 degrees).
constexpr double kMaxSearchRadius = 10.0;
}  // namespace

PinholeRadtanCamera::PinholeRadtanCamera(const PinholeRadtanParams& params) : params_(params) {
  if (!(params_.fx > 0.0 && params_.fy > 0.0))
    fail("pinhole camera: fx and fy must be positive, got {} {}", params_.fx, params_.fy);
  if (params_.width <= 0 || params_.height <= 0)
    fail("pinhole camera: image size must be positive, got {}x{}", params_.width, params_.height);
  for (double v :
       {params_.cx, params_.cy, params_.k1, params_.k2, params_.p1, params_.p2, params_.k3})
    if (!std::isfinite(v)) fail("pinhole camera: a parameter is not finite");
  if (!hasDistortion()) {
    r2_max_ = std::numeric_limits<double>::infinity();
    return;
  }
  // r (1 + k1 r^2 + k2 r^4 + k3 r^6) must increase: d/dr = 1 + 3 k1 r^2 + 5 k2 r^4 + 7 k3 r^6 > 0.
  const auto& p = params_;
  constexpr double kStep = 1e-3;
  double r = 0.0;
  while (r + kStep <= kMaxSearchRadius) {
    const double r2 = (r + kStep) * (r + kStep);
    if (!(1.0 + r2 * (3.0 * p.k1 + r2 * (5.0 * p.k2 + r2 * 7.0 * p.k3)) > 0.0)) break;
    r += kStep;
  }
  r2_max_ = r * r;
}

PinholeRadtanCamera::PinholeRadtanCamera(double fx, double fy, double cx, double cy, int width,
                                         int height)
    : PinholeRadtanCamera(PinholeRadtanParams{
          .fx = fx, .fy = fy, .cx = cx, .cy = cy, .width = width, .height = height}) {}

bool PinholeRadtanCamera::hasDistortion() const {
  const auto& p = params_;
  return p.k1 != 0.0 || p.k2 != 0.0 || p.p1 != 0.0 || p.p2 != 0.0 || p.k3 != 0.0;
}

Vec2 PinholeRadtanCamera::distort(const Vec2& xy, Eigen::Matrix2d* d_xyd_d_xy) const {
  const auto& p = params_;
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (p.k1 + r2 * (p.k2 + r2 * p.k3));
  if (d_xyd_d_xy) {
    const double d_radial_d_r2 = p.k1 + r2 * (2.0 * p.k2 + r2 * 3.0 * p.k3);
    const double cross = 2.0 * x * y * d_radial_d_r2 + 2.0 * p.p1 * x + 2.0 * p.p2 * y;
    *d_xyd_d_xy << radial + 2.0 * x * x * d_radial_d_r2 + 2.0 * p.p1 * y + 6.0 * p.p2 * x, cross,
        cross, radial + 2.0 * y * y * d_radial_d_r2 + 6.0 * p.p1 * y + 2.0 * p.p2 * x;
  }
  return Vec2(x * radial + 2.0 * p.p1 * x * y + p.p2 * (r2 + 2.0 * x * x),
              y * radial + p.p1 * (r2 + 2.0 * y * y) + 2.0 * p.p2 * x * y);
}

std::optional<Vec2> PinholeRadtanCamera::project(const Vec3& p_C,
                                                 Eigen::Matrix<double, 2, 3>* d_px_d_p) const {
  const auto& p = params_;
  const double z = p_C.z();
  if (!(z > 1e-9 * p_C.norm())) return std::nullopt;
  const Vec2 xy(p_C.x() / z, p_C.y() / z);
  if (!(xy.squaredNorm() <= r2_max_)) return std::nullopt;
  Eigen::Matrix2d D;
  const Vec2 xyd = distort(xy, d_px_d_p ? &D : nullptr);
  const Eigen::Matrix2d F = Eigen::Vector2d(p.fx, p.fy).asDiagonal();
  if (d_px_d_p) {
    Eigen::Matrix<double, 2, 3> d_xy_d_p;
    d_xy_d_p << 1.0 / z, 0.0, -xy.x() / z, 0.0, 1.0 / z, -xy.y() / z;
    *d_px_d_p = F * D * d_xy_d_p;
  }
  return Vec2(F * xyd + Vec2(p.cx, p.cy));
}

std::optional<Vec3> PinholeRadtanCamera::unproject(const Vec2& px) const {
  const auto& p = params_;
  const Vec2 xyd((px.x() - p.cx) / p.fx, (px.y() - p.cy) / p.fy);
  Vec2 xy = xyd;
  if (hasDistortion()) {
    bool converged = false;
    for (int i = 0; i < 50 && !converged; ++i) {
      Eigen::Matrix2d D;
      const Vec2 f = distort(xy, &D) - xyd;
      if (f.norm() < 1e-13) {
        converged = true;
        break;
      }
      xy -= D.partialPivLu().solve(f);
      if (!xy.allFinite()) return std::nullopt;
    }
    if (!converged && !((distort(xy, nullptr) - xyd).norm() < 1e-10)) return std::nullopt;
    if (!(xy.squaredNorm() <= r2_max_)) return std::nullopt;
  }
  return Vec3(xy.x(), xy.y(), 1.0).normalized();
}

bool PinholeRadtanCamera::isValid(const Vec2& px) const {
  if (!(px.x() >= 0.0 && px.y() >= 0.0 && px.x() <= params_.width - 1 &&
        px.y() <= params_.height - 1))
    return false;
  return unproject(px).has_value();
}

}  // namespace ovo::camera
