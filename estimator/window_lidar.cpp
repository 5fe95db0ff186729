#include "estimator/window_lidar.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace ovo::estimator {

std::vector<BeamInImage> projectScan(const LidarScan& scan, const camera::Camera& camera,
                                     const SE3& T_C_L) {
  std::vector<BeamInImage> out;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    const Vec3 p_C = T_C_L * scan.point_L(i);
    if (!p_C.allFinite() || p_C.norm() < 1e-3) continue;
    const auto px = camera::project(camera, p_C);
    if (!px || !camera::isValid(camera, *px)) continue;
    out.push_back({scan.ranges_m[i], p_C, *px});
  }
  return out;
}

std::vector<BeamMatch> associateBeams(const std::vector<BeamInImage>& beams,
                                      const std::vector<TrackObservation>& observations,
                                      double radius_px) {
  // Grid of observations with cells of radius_px for a local search.
  const double cell = std::max(1.0, radius_px);
  auto key = [cell](double u, double v) {
    return (static_cast<std::int64_t>(std::floor(u / cell)) << 32) ^
           static_cast<std::int64_t>(static_cast<std::uint32_t>(std::floor(v / cell)));
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
