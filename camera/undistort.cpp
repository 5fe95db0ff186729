#include "camera/undistort.hpp"

#include <cmath>
#include <numbers>

namespace ovo::camera {

RemapTable perspectiveUndistortionMap(const Camera& cam, double sf) {
  RemapTable table;
  table.width = width(cam);
  table.height = height(cam);
  const std::size_t n = static_cast<std::size_t>(table.width) * table.height;
  table.map_u.assign(n, -1.0f);
  table.map_v.assign(n, -1.0f);
  const double half_w = table.width / 2.0, half_h = table.height / 2.0;
  // OCamCalib's M = (i - H/2, j - W/2, -W/sf) in its (row, col, backwards) axes is
  // p_C = (j - W/2, i - H/2, W/sf) in ovo's camera frame.
  const double depth = table.width / sf;
  std::visit(
      [&](const auto& model) {
        for (int i = 0; i < table.height; ++i)
          for (int j = 0; j < table.width; ++j) {
            const auto px = model.project(Vec3(j - half_w, i - half_h, depth));
            if (!px) continue;
            const std::size_t k = static_cast<std::size_t>(i) * table.width + j;
            table.map_u[k] = static_cast<float>(px->x());
            table.map_v[k] = static_cast<float>(px->y());
          }
      },
      cam);
  return table;
}

RemapTable panoramicUndistortionMap(double center_row, double center_col, double rmin_px,
                                    double rmax_px, int width, int height) {
  RemapTable table;
  table.width = width;
  table.height = height;
  const std::size_t n = static_cast<std::size_t>(width) * height;
  table.map_u.resize(n);
  table.map_v.resize(n);
  for (int i = 0; i < height; ++i) {
    const double rho = rmax_px - (rmax_px - rmin_px) / height * i;
    for (int j = 0; j < width; ++j) {
      const double angle = -static_cast<double>(j) / width * 2.0 * std::numbers::pi;
      const std::size_t k = static_cast<std::size_t>(i) * width + j;
      table.map_u[k] = static_cast<float>(center_col + rho * std::sin(angle));
      table.map_v[k] = static_cast<float>(center_row + rho * std::cos(angle));
    }
  }
  return table;
}

}  // namespace ovo::camera
