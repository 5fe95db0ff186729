// The ray caster: a per-pixel bearing look-up table built once from camera.unproject (any camera
// model, fisheye rays beyond 90 degrees included) and a parallel render of the world's radiance,
// taken at one instant (global shutter) or row by row (rolling shutter: a pose and time a row).
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "camera/camera.hpp"
#include "common/types.hpp"
#include "sim/scenario.hpp"
#include "sim/world.hpp"

namespace ovo::sim {

class Renderer {
 public:
  Renderer(const camera::Camera& camera, const RenderOptions& options);

  int width() const { return width_; }
  int height() const { return height_; }
  /// CV_8U, 255 where the camera's isValid() holds at the pixel centre.
  const cv::Mat& validMask() const { return valid_; }

  /// Radiance image (CV_32F, display units: 1 = white) of the world seen from T_W_C at t_s;
  /// 0 outside the valid area. Rows are rendered in parallel (TBB).
  cv::Mat renderRadiance(const VineyardWorld& world, const SE3& T_W_C, double t_s) const;
  /// The same with row v seen from T_W_C_rows[v] at t_rows[v] (a rolling shutter); both hold
  /// height() entries. Rows with equal poses and times render exactly as the overload above.
  cv::Mat renderRadiance(const VineyardWorld& world, const std::vector<SE3>& T_W_C_rows,
                         const std::vector<double>& t_rows) const;
  /// Mean radiance over every `stride`-th valid pixel in both directions (pixel centres), as an
  /// exposure meter sees the view.
  double meanRadiance(const VineyardWorld& world, const SE3& T_W_C, double t_s,
                      int stride = 8) const;

 private:
  struct Sample {
    float x, y, z;  // unit bearing in C
  };
  void renderRow(const VineyardWorld& world, int v, const SE3& T_W_C, double t_s, float* out) const;

  int width_ = 0, height_ = 0, samples_ = 1;
  std::vector<Sample> bearings_;  // samples_ per pixel, row-major; zero vector = invalid
  std::vector<float> footprint_;  // filter width per pixel (radians)
  cv::Mat valid_;
};

}  // namespace ovo::sim
