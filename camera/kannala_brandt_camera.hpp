// Kannala-Brandt / equidistant fisheye model as OpenCV cv::fisheye and Kalibr `equidistant`
// (Kannala, Brandt, "A Generic Camera Model and Calibration Method...", TPAMI 2006):
// theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8), u = fx theta_d x / r +
// cx.
#pragma once

#include <Eigen/Core>
#include <optional>

#include "common/types.hpp"

namespace ovo::camera {

/// Intrinsics of a Kannala-Brandt camera.
struct KannalaBrandtParams {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // pixels
  double k1 = 0.0, k2 = 0.0, k3 = 0.0, k4 = 0.0;  // theta_d polynomial (radians)
  int width = 0, height = 0;                      // pixels
};

/// Kannala-Brandt camera; works beyond 90 degrees off-axis up to where theta_d(theta) stops
/// increasing (at most 180 degrees).
class KannalaBrandtCamera {
 public:
  /// Throws ovo::Error when fx, fy or the size are not positive.
  explicit KannalaBrandtCamera(const KannalaBrandtParams& params);

  std::optional<Vec3> unproject(const Vec2& px) const;
  std::optional<Vec2> project(const Vec3& p_C,
                              Eigen::Matrix<double, 2, 3>* d_px_d_p = nullptr) const;
  bool isValid(const Vec2& px) const;
  int width() const { return params_.width; }
  int height() const { return params_.height; }
  double focalPx() const { return 0.5 * (params_.fx + params_.fy); }

  const KannalaBrandtParams& params() const { return params_; }
  double maxOffAxisRad() const { return theta_max_rad_; }

 private:
  double distort(double theta) const;       // theta_d
  double distortDeriv(double theta) const;  // d theta_d / d theta

  KannalaBrandtParams params_;
  double theta_max_rad_ = 0.0;
  double theta_d_max_ = 0.0;
};

}  // namespace ovo::camera
