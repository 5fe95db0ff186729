#include "calib/model_comparison.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

namespace ovo::calib {

BearingComparison compareBearings(const camera::Camera& reference, const camera::Camera& other,
                                  int step_px, bool align_roll, double max_off_axis_deg) {
  const double min_z = max_off_axis_deg > 0.0 ? std::cos(max_off_axis_deg * M_PI / 180.0) : -2.0;
  BearingComparison out;
  std::vector<std::pair<Vec3, Vec3>> pairs;
  const int step = std::max(1, step_px);
  for (int v = 0; v < camera::height(reference); v += step)
    for (int u = 0; u < camera::width(reference); u += step) {
      const Vec2 px(u, v);
      if (!camera::isValid(reference, px)) continue;
      const auto a = camera::unproject(reference, px);
      if (!a || a->z() < min_z) continue;
      ++out.pixels;
      const auto b = camera::unproject(other, px);
      if (!b) {
        ++out.missing;
        continue;
      }
      pairs.emplace_back(*a, *b);
    }
  // Roll eps maximising sum a . Rz(eps) b.
  double eps = 0.0;
  if (align_roll) {
    double s = 0.0, c = 0.0;
    for (const auto& [a, b] : pairs) {
      c += a.x() * b.x() + a.y() * b.y();
      s += a.y() * b.x() - a.x() * b.y();
    }
    eps = std::atan2(s, c);
  }
  const Mat3 Rz = Eigen::AngleAxisd(eps, Vec3::UnitZ()).toRotationMatrix();
  double sum2 = 0.0;
  for (const auto& [a, b] : pairs)
    out.max_unaligned_deg =
        std::max(out.max_unaligned_deg, std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180.0 / M_PI);
  for (const auto& [a, b] : pairs) {
    const double angle = std::acos(std::clamp(a.dot(Rz * b), -1.0, 1.0)) * 180.0 / M_PI;
    out.max_deg = std::max(out.max_deg, angle);
    sum2 += angle * angle;
  }
  if (out.missing > 0) out.max_deg = out.max_unaligned_deg = 180.0;
  out.rms_deg = pairs.empty() ? 0.0 : std::sqrt(sum2 / pairs.size());
  out.roll_deg = eps * 180.0 / M_PI;
  return out;
}

}  // namespace ovo::calib
