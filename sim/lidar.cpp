#include "sim/lidar.hpp"

#include <cmath>
#include <limits>

#include "sim/random.hpp"

namespace ovo::sim {

int lidarBeamCount(const LidarOptions& o) {
  return static_cast<int>(
             std::floor((o.angle_max_deg - o.angle_min_deg) / o.angle_increment_deg + 1e-9)) +
         1;
}

namespace {

// Beam i from T_W_L_at(i) at time t_at(i).
template <typename PoseAt, typename TimeAt>
LidarScan castScan(const VineyardWorld& world, const PoseAt& T_W_L_at, const TimeAt& t_at,
                   Timestamp t_ns, const LidarOptions& o, std::uint64_t noise_seed) {
  constexpr double kDeg = M_PI / 180.0;
  Rng rng(noise_seed);
  LidarScan scan;
  scan.t_ns = t_ns;
  scan.angle_min_rad = o.angle_min_deg * kDeg;
  scan.angle_increment_rad = o.angle_increment_deg * kDeg;
  scan.range_min_m = o.range_min_m;
  scan.range_max_m = o.range_max_m;
  const int n = lidarBeamCount(o);
  scan.ranges_m.assign(n, std::numeric_limits<double>::quiet_NaN());
  for (int i = 0; i < n; ++i) {
    const SE3& T_W_L = T_W_L_at(i);
    const double a = scan.angle(i);
    const Vec3 dir_W = T_W_L.linear() * Vec3(std::cos(a), std::sin(a), 0.0);
    const auto range = world.firstOpaqueHit(T_W_L.translation(), dir_W, o.range_max_m, t_at(i));
    const double noise = o.noise ? o.range_sigma_m * rng.normal() : 0.0;
    const bool dropout = o.noise && rng.uniform() < o.dropout_probability;
    if (!range || dropout) continue;
    const double r = *range + noise;
    if (r >= o.range_min_m && r <= o.range_max_m) scan.ranges_m[i] = r;
  }
  return scan;
}

}  // namespace

LidarScan simulateScan(const VineyardWorld& world, const SE3& T_W_L, double t_s, Timestamp t_ns,
                       const LidarOptions& o, std::uint64_t noise_seed) {
  return castScan(
      world, [&](int) -> const SE3& { return T_W_L; }, [&](int) { return t_s; }, t_ns, o,
      noise_seed);
}

LidarScan simulateSweptScan(const VineyardWorld& world, const std::function<SE3(double)>& T_W_L_at,
                            double t_s, Timestamp t_ns, double time_increment_s,
                            const LidarOptions& o, std::uint64_t noise_seed) {
  SE3 pose;
  const auto beam_time = [&](int i) { return t_s + i * time_increment_s; };
  LidarScan scan = castScan(
      world,
      [&](int i) -> const SE3& {
        pose = T_W_L_at(beam_time(i));
        return pose;
      },
      beam_time, t_ns, o, noise_seed);
  scan.time_increment_s = time_increment_s;
  return scan;
}

}  // namespace ovo::sim
