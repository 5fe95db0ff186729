// The camera height from a downward-pitched LiDAR's ground beams.
#include "estimator/common/lidar_ground.hpp"

#include <algorithm>
#include <cmath>
#include <utility>

namespace ovo::estimator {
namespace {

// The largest run of sorted values within `width` of its first: (first index, count).
std::pair<std::size_t, std::size_t> densestRun(const std::vector<double>& sorted, double width) {
  std::size_t best_lo = 0, best_n = 0;
  for (std::size_t lo = 0, hi = 0; lo < sorted.size(); ++lo) {
    while (hi < sorted.size() && sorted[hi] <= sorted[lo] + width) ++hi;
    if (hi - lo > best_n) best_n = hi - lo, best_lo = lo;
  }
  return {best_lo, best_n};
}

}  // namespace

std::optional<double> bodyHeightFromScan(const LidarScan& scan, const SE3& T_B_L,
                                         const LidarGroundOptions& options) {
  const double z_lidar = T_B_L.translation().z();
  std::vector<double> low;
  int valid = 0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    ++valid;
    const double z = (T_B_L * scan.point_L(i)).z();
    if (std::isfinite(z) && z <= z_lidar - options.min_drop_m) low.push_back(z);
  }
  if (low.empty()) return std::nullopt;
  std::sort(low.begin(), low.end());
  // The densest band: the most end points within band_m of each other.
  const auto [best_lo, best_n] = densestRun(low, options.band_m);
  if (static_cast<int>(best_n) < options.min_points ||
      static_cast<double>(best_n) < options.min_fraction * valid)
    return std::nullopt;
  // Nothing is seen below the ground: a band with end points further down is a wall's (the
  // height of a pitched scan's hits on a wall changes slowest where they are least below it).
  const auto below = std::lower_bound(low.begin(), low.end(), low[best_lo] - options.band_m);
  if (static_cast<double>(below - low.begin()) > options.max_below_fraction * best_n)
    return std::nullopt;
  return -low[best_lo + best_n / 2];
}

std::optional<LidarCameraHeight> cameraHeightFromLidar(const std::vector<LidarScan>& scans,
                                                       const SE3& T_B_L, const SE3& T_B_C,
                                                       const LidarGroundOptions& options) {
  LidarCameraHeight out;
  std::vector<double> heights;
  for (const LidarScan& scan : scans) {
    if (out.scans_seen >= options.max_scans) break;
    ++out.scans_seen;
    if (auto h = bodyHeightFromScan(scan, T_B_L, options)) heights.push_back(*h);
  }
  out.scans_used = static_cast<int>(heights.size());
  std::sort(heights.begin(), heights.end());
  const auto [best_lo, best_n] = densestRun(heights, options.agreement_m);
  out.scans_agreeing = static_cast<int>(best_n);
  if (out.scans_agreeing < options.min_scans ||
      out.scans_agreeing < options.min_agreeing * out.scans_used)
    return std::nullopt;
  const double body_height = heights[best_lo + best_n / 2];
  out.camera_height_m = body_height + T_B_C.translation().z();
  if (!(out.camera_height_m > 0.0)) return std::nullopt;
  return out;
}

}  // namespace ovo::estimator
