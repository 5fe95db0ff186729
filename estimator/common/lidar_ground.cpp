// The camera height from a downward-pitched LiDAR's ground beams.
#include "estimator/common/lidar_ground.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
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

// The body heights z of the scan's end points min_drop_m or more below the LiDAR, sorted, and the
// number of valid beams.
std::pair<std::vector<double>, int> lowEndPoints(const LidarScan& scan, const SE3& T_B_L,
                                                 double min_drop_m) {
  const double z_lidar = T_B_L.translation().z();
  std::vector<double> low;
  int valid = 0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    ++valid;
    const double z = (T_B_L * scan.point_L(i)).z();
    if (std::isfinite(z) && z <= z_lidar - min_drop_m) low.push_back(z);
  }
  std::sort(low.begin(), low.end());
  return {std::move(low), valid};
}

// The ground's band among the sorted low end points: the median height of the densest run within
// `width`, nullopt when the run has too few points or too many lie more than `width` below it.
std::optional<double> groundBand(const std::vector<double>& low, int valid, double width,
                                 const LidarGroundOptions& options) {
  if (low.empty()) return std::nullopt;
  const auto [best_lo, best_n] = densestRun(low, width);
  if (static_cast<int>(best_n) < options.min_points ||
      static_cast<double>(best_n) < options.min_fraction * valid)
    return std::nullopt;
  // Nothing is seen below the ground: a band with end points further down is a wall's (the
  // height of a pitched scan's hits on a wall changes slowest where they are least below it).
  const auto below = std::lower_bound(low.begin(), low.end(), low[best_lo] - width);
  if (static_cast<double>(below - low.begin()) > options.max_below_fraction * best_n)
    return std::nullopt;
  return low[best_lo + best_n / 2];
}

}  // namespace

std::optional<double> bodyHeightFromScan(const LidarScan& scan, const SE3& T_B_L,
                                         const LidarGroundOptions& options) {
  const auto [low, valid] = lowEndPoints(scan, T_B_L, options.min_drop_m);
  // The densest band: the most end points within band_m of each other.
  const auto z = groundBand(low, valid, options.band_m, options);
  if (!z) return std::nullopt;
  return -*z;
}

std::optional<GroundRoughness> groundRoughnessFromScan(const LidarScan& scan, const SE3& T_B_L,
                                                       double range_sigma_m,
                                                       const LidarGroundOptions& options) {
  // The ground found as bodyHeightFromScan finds it, in a band as wide as the gate (rough ground
  // spreads its end points over more than band_m).
  // A body rolled over rough ground puts one side of the line lower than the band: what lies below
  // the ground is checked against the fitted line instead (below).
  const double z_lidar = T_B_L.translation().z();
  struct Point {
    double x, y, z, up;  // up: the beam's |up component| in the body
  };
  std::vector<Point> low;
  int valid = 0;
  for (std::size_t i = 0; i < scan.ranges_m.size(); ++i) {
    if (!scan.valid(i)) continue;
    ++valid;
    const Vec3 p = T_B_L * scan.point_L(i);
    if (!p.allFinite() || p.z() > z_lidar - options.min_drop_m) continue;
    const double angle = scan.angle(i);
    const Vec3 beam_B = T_B_L.linear() * Vec3(std::cos(angle), std::sin(angle), 0.0);
    low.push_back({p.x(), p.y(), p.z(), std::abs(beam_B.z())});
  }
  std::vector<double> low_z;
  for (const Point& p : low) low_z.push_back(p.z);
  std::sort(low_z.begin(), low_z.end());
  LidarGroundOptions seed = options;
  seed.max_below_fraction = std::numeric_limits<double>::infinity();
  const auto band = groundBand(low_z, valid, options.roughness_gate_m, seed);
  if (!band) return std::nullopt;
  // z = a + b y by least squares over the end points within the gate, from the band's height;
  // the gate then narrows to 4 robust spreads (at least 2 cm) and the line is fitted again.
  double a = *band, b = 0.0, gate = options.roughness_gate_m;
  GroundRoughness out;
  std::vector<double> residuals, up_shares;
  std::vector<const Point*> kept;  // the points about the line
  for (int iteration = 0; iteration < 4; ++iteration) {
    double n = 0, sy = 0, sz = 0, syy = 0, syz = 0;
    for (const Point& p : low) {
      if (std::abs(p.z - a - b * p.y) > gate) continue;
      n += 1, sy += p.y, sz += p.z, syy += p.y * p.y, syz += p.y * p.z;
    }
    if (n < options.min_points) return std::nullopt;
    const double det = n * syy - sy * sy;
    if (!(det > 1e-9 * n * n)) return std::nullopt;  // all at one y: no line across the scan
    b = (n * syz - sy * sz) / det;
    a = (sz - b * sy) / n;
    residuals.clear();
    up_shares.clear();
    kept.clear();
    for (const Point& p : low)
      if (const double r = std::abs(p.z - a - b * p.y); r <= gate) {
        residuals.push_back(r);
        up_shares.push_back(p.up);
        kept.push_back(&p);
      }
    out.points = static_cast<int>(residuals.size());
    if (out.points < options.min_points) return std::nullopt;
    std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
    out.spread_m = 1.4826 * residuals[residuals.size() / 2];
    gate = std::min(std::max(4.0 * out.spread_m, 0.02), options.roughness_gate_m);
  }
  // The ground's hits lie across the body, one beside the other; a wall's (a slab beside the
  // robot, a post) run along it, ahead: their lateral spread must exceed their spread ahead, and
  // (a slab on either side) of 8 equal parts of their lateral extent, 6 must hold hits.
  {
    double mx = 0, my = 0;
    for (const Point* p : kept) mx += p->x / kept.size(), my += p->y / kept.size();
    double vx = 0, vy = 0;
    for (const Point* p : kept) vx += (p->x - mx) * (p->x - mx), vy += (p->y - my) * (p->y - my);
    if (!(vy > vx)) return std::nullopt;
    constexpr int kParts = 8, kPartsHeld = 6;
    double y_min = kept.front()->y, y_max = y_min;
    for (const Point* p : kept) y_min = std::min(y_min, p->y), y_max = std::max(y_max, p->y);
    std::array<bool, kParts> held{};
    for (const Point* p : kept) {
      const int part = static_cast<int>(kParts * (p->y - y_min) / std::max(y_max - y_min, 1e-9));
      held[std::clamp(part, 0, kParts - 1)] = true;
    }
    if (std::count(held.begin(), held.end(), true) < kPartsHeld) return std::nullopt;
  }
  // Nothing is seen below the ground: a line with end points well below it is a wall's.
  const auto below = std::count_if(low.begin(), low.end(), [&](const Point& p) {
    return p.z < a + b * p.y - options.roughness_gate_m;
  });
  if (static_cast<double>(below) > options.max_below_fraction * out.points) return std::nullopt;
  std::nth_element(up_shares.begin(), up_shares.begin() + up_shares.size() / 2, up_shares.end());
  out.noise_m = range_sigma_m * up_shares[up_shares.size() / 2];
  return out;
}

std::optional<double> terrainRoughness(const std::deque<GroundRoughness>& scans, int min_scans) {
  if (scans.empty() || static_cast<int>(scans.size()) < min_scans) return std::nullopt;
  std::vector<double> spreads, noises;
  for (const GroundRoughness& r : scans) {
    spreads.push_back(r.spread_m);
    noises.push_back(r.noise_m);
  }
  const auto median = [](std::vector<double>& v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double spread = median(spreads), noise = median(noises);
  return std::sqrt(std::max(0.0, spread * spread - noise * noise));
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
