// Pinhole camera with radial-tangential (Brown-Conrady) distortion as OpenCV cv::projectPoints and
// Kalibr `radtan`: k1 k2 p1 p2 [k3]. All zero is the ideal pinhole (rectified KITTI).
#pragma once

#include <Eigen/Core>
#include <optional>

#include "common/types.hpp"

namespace ovo::camera {

/// Intrinsics of a pinhole radial-tangential camera.
struct PinholeRadtanParams {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // pixels
  double k1 = 0.0, k2 = 0.0, p1 = 0.0, p2 = 0.0, k3 = 0.0;
  int width = 0, height = 0;  // pixels
};

/// Pinhole radial-tangential camera; projects points with z > 1e-9 |p| whose normalised radius
/// stays where the radial distortion is monotonic.
class PinholeRadtanCamera {
 public:
  /// Throws ovo::Error when fx, fy or the size are not positive.
  explicit PinholeRadtanCamera(const PinholeRadtanParams& params);
  /// Ideal pinhole (e.g. KITTI P0: fx fy cx cy, image size).
  PinholeRadtanCamera(double fx, double fy, double cx, double cy, int width, int height);

  std::optional<Vec3> unproject(const Vec2& px) const;
  std::optional<Vec2> project(const Vec3& p_C,
                              Eigen::Matrix<double, 2, 3>* d_px_d_p = nullptr) const;
  bool isValid(const Vec2& px) const;
  int width() const { return params_.width; }
  int height() const { return params_.height; }
  double focalPx() const { return 0.5 * (params_.fx + params_.fy); }

  const PinholeRadtanParams& params() const { return params_; }
  bool hasDistortion() const;

 private:
  // Distorted normalised point of (x, y) = (X/Z, Y/Z) and its 2x2 Jacobian.
  Vec2 distort(const Vec2& xy, Eigen::Matrix2d* d_xyd_d_xy) const;

  PinholeRadtanParams params_;
  double r2_max_ = 0.0;  // largest undistorted r^2 where r (1 + k1 r^2 + ...) still increases
};

}  // namespace ovo::camera
