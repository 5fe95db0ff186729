// Undistortion look-up tables as OCamCalib's C "undistortFunctions" build them: for every output
// pixel, the input pixel to sample (bilinear, black outside). No image library here: apply the
// tables with cv::remap (apps/cmd_undistort.cpp) or any bilinear sampler.
#pragma once

#include <vector>

#include "camera/camera.hpp"

namespace ovo::camera {

/// Per output pixel (row-major), the input column (map_u) and row (map_v); -1 where no input
/// pixel exists (outside the model's domain).
struct RemapTable {
  int width = 0, height = 0;
  std::vector<float> map_u, map_v;
};

/// Perspective view of the input's size: output pixel (row i, col j) looks along the ray
/// p_C = (j - W/2, i - H/2, W/sf), i.e. OCamCalib's M = (i - H/2, j - W/2, -W/sf) (DESIGN section
/// 3). Larger sf = wider view.
RemapTable perspectiveUndistortionMap(const Camera& cam, double sf);

/// Panoramic unwrapping around the image centre (row, col): output (row i, col j) samples the
/// input at radius rho = rmax - (rmax - rmin) i / height and angle -2 pi j / width, as the
/// toolbox's create_panoramic_undistortion_LUT.
RemapTable panoramicUndistortionMap(double center_row, double center_col, double rmin_px,
                                    double rmax_px, int width, int height);

}  // namespace ovo::camera
