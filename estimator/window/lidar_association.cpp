// Scan beams projected into the image and paired with tracked observations.
#include "estimator/window/lidar_association.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace ovo::estimator {

namespace {

// True when the scan's beams close the circle: n |increment| within half an increment of 2 pi
// (its last beam is then next to its first).
bool closesCircle(const LidarScan& scan) {
  const double step = std::abs(scan.angle_increment_rad);
  return step > 0.0 &&
         std::abs(static_cast<double>(scan.ranges_m.size()) * step - 2.0 * M_PI) <= 0.5 * step;
}

// Beam k of the scan's grid (wrapped around a scan that closes the circle); -1 outside the scan.
long beamAt(const LidarScan& scan, long k) {
  const auto n = static_cast<long>(scan.ranges_m.size());
  if (k >= 0 && k < n) return k;
  if (!closesCircle(scan) || n == 0) return -1;
  return ((k % n) + n) % n;
}

bool smoothAround(const LidarScan& scan, std::size_t i, double max_step_fraction, int neighbours) {
  const long c = static_cast<long>(i);
  const double max_step = max_step_fraction * scan.ranges_m[i];
  for (long k = c - neighbours; k < c + neighbours; ++k) {
    const long a = beamAt(scan, k), b = beamAt(scan, k + 1);
    if (a < 0 || b < 0) return false;
    if (!scan.valid(static_cast<std::size_t>(a)) || !scan.valid(static_cast<std::size_t>(b)))
      return false;
    if (std::abs(scan.ranges_m[b] - scan.ranges_m[a]) > max_step) return false;
  }
  return true;
}

}  // namespace

std::vector<BeamInImage> projectScan(const LidarScan& scan, const camera::Camera& camera,
                                     const SE3& T_C_L, double max_step_fraction, int neighbours) {
  std::vector<BeamInImage> out;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    if (max_step_fraction > 0.0 && !smoothAround(scan, i, max_step_fraction, neighbours)) continue;
    const Vec3 p_C = T_C_L * scan.point_L(i);
    if (!p_C.allFinite() || p_C.norm() < 1e-3) continue;
    const auto px = camera::project(camera, p_C);
    if (!px || !camera::isValid(camera, *px)) continue;
    out.push_back({scan.ranges_m[i], p_C, *px});
  }
  return out;
}

std::optional<double> scanGridPosition(const LidarScan& scan, double phi_rad) {
  const double inc = scan.angle_increment_rad;
  const std::size_t n = scan.ranges_m.size();
  if (!(std::abs(inc) > 0.0) || !std::isfinite(inc) || n < 2 || !std::isfinite(phi_rad) ||
      !std::isfinite(scan.angle_min_rad))
    return std::nullopt;
  // phi's offset from the first beam, taken modulo 2 pi onto the side the scan sweeps (a scan
  // published as 0..2 pi, or from +pi down to -pi, reads the same as one from -pi up to pi).
  constexpr double kTwoPi = 2.0 * M_PI;
  double d = (phi_rad - scan.angle_min_rad) * (inc > 0.0 ? 1.0 : -1.0);
  d -= kTwoPi * std::floor(d / kTwoPi);
  const double f = d / std::abs(inc);
  const double last = static_cast<double>(closesCircle(scan) ? n : n - 1);
  if (!(f >= 0.0) || f >= last) return std::nullopt;
  return f;
}

std::optional<double> interpolateRange(const LidarScan& scan, double phi_rad,
                                       double max_step_fraction, int neighbours) {
  const auto f = scanGridPosition(scan, phi_rad);
  if (!f) return std::nullopt;
  const auto i0 = static_cast<std::size_t>(*f);
  const auto i1 = static_cast<std::size_t>(beamAt(scan, static_cast<long>(i0) + 1));
  for (const std::size_t i : {i0, i1})
    if (!scan.valid(i) ||
        (max_step_fraction > 0.0 && !smoothAround(scan, i, max_step_fraction, neighbours)))
      return std::nullopt;
  const double a = *f - static_cast<double>(i0);
  return (1.0 - a) * scan.ranges_m[i0] + a * scan.ranges_m[i1];
}

std::optional<double> groundRangeAlongRay(const Vec3& hit_L, const Vec3& up_L, const Vec3& c_L,
                                          const Vec3& b_L) {
  const Vec3 b = b_L.normalized();
  const double nb = up_L.dot(b);
  if (!(nb < -0.02)) return std::nullopt;
  const double s = up_L.dot(hit_L - c_L) / nb;
  if (!(s > 0.0)) return std::nullopt;
  const double d = (c_L + s * b).head<2>().norm();
  return std::isfinite(d) ? std::optional<double>(d) : std::nullopt;
}

double groundIncidenceSine(const Vec3& hit_L, const Vec3& up_L) {
  const double r = hit_L.norm();
  return r > 0.0 ? std::abs(up_L.dot(hit_L)) / r : 0.0;
}

std::vector<BeamMatch> associateBeams(const std::vector<BeamInImage>& beams,
                                      const std::vector<TrackObservation>& observations,
                                      double radius_px) {
  // Grid of observations with cells of radius_px for a local search.
  const double cell = std::max(1.0, radius_px);
  // A cell's index through int64 (clamped, a non-finite coordinate in cell 0): a negative or
  // huge double converted straight to an unsigned or too narrow integer is undefined behaviour.
  auto index = [cell](double x) -> std::int64_t {
    const double c = std::floor(x / cell);
    return std::isfinite(c) ? static_cast<std::int64_t>(std::clamp(c, -1e9, 1e9)) : 0;
  };
  auto key = [&index](double u, double v) {
    return static_cast<std::int64_t>(
        (static_cast<std::uint64_t>(index(u)) << 32) ^
        static_cast<std::uint64_t>(static_cast<std::uint32_t>(index(v))));
  };
  std::unordered_map<std::int64_t, std::vector<int>> grid;
  for (int i = 0; i < static_cast<int>(observations.size()); ++i)
    grid[key(observations[i].px.x(), observations[i].px.y())].push_back(i);

  std::unordered_map<TrackId, std::pair<double, BeamMatch>> best;  // track -> (px distance, match)
  const double r2 = radius_px * radius_px;
  for (const BeamInImage& beam : beams) {
    int nearest = -1;
    double nearest_d2 = r2;
    for (int du = -1; du <= 1; ++du) {
      for (int dv = -1; dv <= 1; ++dv) {
        auto it = grid.find(key(beam.px.x() + du * cell, beam.px.y() + dv * cell));
        if (it == grid.end()) continue;
        for (int i : it->second) {
          const double d2 = (observations[i].px - beam.px).squaredNorm();
          if (d2 <= nearest_d2) {
            nearest_d2 = d2;
            nearest = i;
          }
        }
      }
    }
    if (nearest < 0) continue;
    const TrackObservation& obs = observations[nearest];
    auto it = best.find(obs.track_id);
    if (it != best.end() && it->second.first <= nearest_d2) continue;
    best[obs.track_id] = {nearest_d2, {obs.track_id, beam.range_m, beam.p_C.norm(), obs.bearing_C}};
  }
  std::vector<BeamMatch> out;
  out.reserve(best.size());
  for (const auto& [id, m] : best) out.push_back(m.second);
  std::sort(out.begin(), out.end(),
            [](const BeamMatch& a, const BeamMatch& b) { return a.track_id < b.track_id; });
  return out;
}

}  // namespace ovo::estimator
