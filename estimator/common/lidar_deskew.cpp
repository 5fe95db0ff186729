// Deskewing a swept scan: its beams moved to the stamp's LiDAR pose and resampled.
#include "estimator/common/lidar_deskew.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "common/so3.hpp"

namespace ovo::estimator {

LidarMotion lidarMotionFromBody(const std::function<Mat3(double tau_s)>& R_B0_B, const Vec3& v_B0,
                                const SE3& T_B_L) {
  return [=](double tau_s) {
    SE3 T_B0_B = SE3::Identity();
    T_B0_B.linear() = R_B0_B(tau_s);
    T_B0_B.translation() = v_B0 * tau_s;
    return SE3(T_B_L.inverse() * T_B0_B * T_B_L);
  };
}

LidarScan deskewScan(const LidarScan& scan, const LidarMotion& motion, double max_step_fraction) {
  if (scan.time_increment_s == 0.0 || scan.ranges_m.empty() || !(scan.angle_increment_rad != 0.0))
    return scan;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = scan.ranges_m.size();
  // Each beam moved into the stamp's frame, as (grid position, range) in its scan plane.
  struct Moved {
    double f = 0.0;  // (angle - angle_min) / increment
    double r = 0.0;
    bool valid = false;
  };
  std::vector<Moved> moved(n);
  double reach = 0.0;  // the furthest a beam moved along the grid, increments
  for (std::size_t i = 0; i < n; ++i) {
    if (!scan.valid(i)) continue;
    const Vec3 p = motion(static_cast<double>(i) * scan.time_increment_s) * scan.point_L(i);
    const double r = std::hypot(p.x(), p.y());
    if (!std::isfinite(r) || r <= 0.0) continue;
    const double a = std::atan2(p.y(), p.x());
    // The moved angle near the beam's own (no wrap across +-pi for a scan's neighbourhood).
    const double a0 = scan.angle(i);
    const double da = std::remainder(a - a0, 2.0 * M_PI);
    moved[i] = {static_cast<double>(i) + da / scan.angle_increment_rad, r, true};
    reach = std::max(reach, std::abs(da / scan.angle_increment_rad));
  }
  const auto span = static_cast<std::size_t>(std::ceil(reach)) + 2;
  LidarScan out = scan;
  out.time_increment_s = 0.0;
  for (std::size_t k = 0; k < n; ++k) {
    const double fk = static_cast<double>(k);
    // The moved beams just below and just above grid position k, searched as far as any beam
    // moved.
    const Moved* lo = nullptr;
    const Moved* hi = nullptr;
    const std::size_t from = k >= span ? k - span : 0, to = std::min(n, k + span + 1);
    for (std::size_t i = from; i < to; ++i) {
      const Moved& m = moved[i];
      if (!m.valid) continue;
      if (m.f <= fk && (!lo || m.f > lo->f)) lo = &m;
      if (m.f >= fk && (!hi || m.f < hi->f)) hi = &m;
    }
    double r = nan;
    if (lo && hi && hi->f - lo->f <= 1.5) {
      const double span = hi->f - lo->f;
      if (std::abs(hi->r - lo->r) > max_step_fraction * std::min(hi->r, lo->r))
        r = fk - lo->f <= hi->f - fk ? lo->r : hi->r;
      else
        r = span > 0.0 ? lo->r + (hi->r - lo->r) * (fk - lo->f) / span : lo->r;
    } else if (lo && fk - lo->f <= 0.5) {
      r = lo->r;
    } else if (hi && hi->f - fk <= 0.5) {
      r = hi->r;
    }
    out.ranges_m[k] = r;
  }
  return out;
}

std::pair<Timestamp, Timestamp> sweepInterval(const LidarScan& scan) {
  const double beams = static_cast<double>(std::max<std::size_t>(scan.ranges_m.size(), 1) - 1);
  const double sweep_s = scan.time_increment_s * beams;
  return {scan.t_ns + fromSeconds(std::min(0.0, sweep_s)),
          scan.t_ns + fromSeconds(std::max(0.0, sweep_s))};
}

Vec3 meanSweepRate(const LidarScan& scan, std::span<const ImuSample> gyro, const Vec3& bias_radps) {
  if (gyro.empty()) return Vec3::Zero();
  const auto [t0, t1] = sweepInterval(scan);
  Vec3 sum = Vec3::Zero();
  int n = 0;
  const ImuSample* nearest = &gyro.front();
  Timestamp nearest_gap = std::numeric_limits<Timestamp>::max();
  for (const ImuSample& g : gyro) {
    const Timestamp gap = g.t_ns < t0 ? t0 - g.t_ns : (g.t_ns > t1 ? g.t_ns - t1 : 0);
    if (gap == 0) sum += g.gyro_radps, ++n;
    if (gap < nearest_gap) nearest_gap = gap, nearest = &g;
  }
  if (n > 0) return sum / n - bias_radps;
  return nearest->gyro_radps - bias_radps;
}

LidarScan deskewScanWithGyro(const LidarScan& scan, std::span<const ImuSample> gyro,
                             const Vec3& bias_radps, const Vec3& v_B, const SE3& T_B_L) {
  if (scan.time_increment_s == 0.0 || scan.ranges_m.size() < 2) return scan;
  const Vec3 w_B = meanSweepRate(scan, gyro, bias_radps);
  return deskewScan(
      scan, lidarMotionFromBody([w_B](double tau_s) { return so3::exp(w_B * tau_s); }, v_B, T_B_L));
}

}  // namespace ovo::estimator
