// The kf's LiDAR scale: scan points associated with features, a robust mean of range ratios.
#include "estimator/common/lidar_scale.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <variant>

namespace ovo::estimator {

LidarScaleOptions readLidarScaleOptions(const Config& config) {
  LidarScaleOptions o;
  o.association_radius_px = config.getInRange("kf.lidar_scale.association_radius_px",
                                              o.association_radius_px, 0.1, 100.0);
  o.min_associations =
      config.getIntInRange("kf.lidar_scale.min_associations", o.min_associations, 1, 100000);
  o.gate_relative = config.getInRange("kf.lidar_scale.gate_relative", o.gate_relative, 0.01, 10.0);
  o.huber_k = config.getInRange("kf.lidar_scale.huber_k", o.huber_k, 0.1, 100.0);
  o.min_range_m = config.getInRange("kf.lidar_scale.min_range_m", o.min_range_m, 0.0, 100.0);
  o.edge_relative = config.getInRange("kf.lidar_scale.edge_relative", o.edge_relative, 0.0, 10.0);
  o.min_parallax_deg =
      config.getInRange("kf.lidar_scale.min_parallax_deg", o.min_parallax_deg, 0.0, 90.0);
  return o;
}

namespace {

// Features binned on a grid of radius-sized cells: the nearest within the radius is in the 3x3
// cells around a query.
class FeatureGrid {
 public:
  FeatureGrid(const std::vector<ScaleFeature>& features, const std::vector<bool>& usable,
              double cell_px)
      : features_(features), cell_px_(cell_px) {
    for (std::size_t i = 0; i < features.size(); ++i)
      if (usable[i])
        cells_[key(cellOf(features[i].px.x()), cellOf(features[i].px.y()))].push_back(i);
  }

  /// Index of the nearest feature within radius_px and its squared distance.
  std::optional<std::pair<std::size_t, double>> nearest(const Vec2& px, double radius_px) const {
    const std::int64_t cx = cellOf(px.x()), cy = cellOf(px.y());
    double best_d2 = radius_px * radius_px;
    std::optional<std::pair<std::size_t, double>> best;
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = cells_.find(key(cx + dx, cy + dy));
        if (it == cells_.end()) continue;
        for (const std::size_t i : it->second) {
          const double d2 = (features_[i].px - px).squaredNorm();
          if (d2 <= best_d2) {
            best_d2 = d2;
            best = std::make_pair(i, d2);
          }
        }
      }
    }
    return best;
  }

 private:
  std::int64_t cellOf(double v) const {
    return static_cast<std::int64_t>(std::floor(v / cell_px_));
  }
  static std::int64_t key(std::int64_t cx, std::int64_t cy) {
    return (cx << 32) ^ (cy & 0xffffffff);
  }

  const std::vector<ScaleFeature>& features_;
  double cell_px_;
  std::unordered_map<std::int64_t, std::vector<std::size_t>> cells_;
};

double median(std::vector<double> v) {
  const std::size_t n = v.size();
  std::nth_element(v.begin(), v.begin() + n / 2, v.end());
  const double upper = v[n / 2];
  if (n % 2 == 1) return upper;
  return 0.5 * (upper + *std::max_element(v.begin(), v.begin() + n / 2));
}

// True when a neighbouring beam is missing or its range differs by more than edge_relative.
bool onDepthEdge(const LidarScan& scan, std::size_t b, double edge_relative) {
  if (edge_relative <= 0.0) return false;
  const double r = scan.ranges_m[b];
  for (const std::size_t n : {b - 1, b + 1}) {
    if (b == 0 && n == b - 1) return true;
    if (n >= scan.ranges_m.size() || !scan.valid(n)) return true;
    if (std::abs(scan.ranges_m[n] - r) > edge_relative * r) return true;
  }
  return false;
}

// The point where the feature's ray b_c meets the surface the beam hit. A planar LiDAR says nothing
// off its plane, and the feature lies a pixel or two off it: the surface is taken as the plane
// through p_C containing the scan's tangent there and the vertical (up_C): a vine row, trunk or
// post. Ground beams (p_C about a camera height below the camera) are skipped: a pitched LiDAR
// meets the ground at a grazing angle where the range hangs on the slope (they read long).
// Without a usable plane, the point at the beam's range along b_c.
std::optional<Vec3> onBeamSurface(const LidarScan& scan, const SE3& T_C_L, std::size_t beam,
                                  const Vec3& p_C, const Vec3& b_c, const Vec3& up_C,
                                  std::optional<double> camera_height_m) {
  const Vec3 along_range = p_C.norm() * b_c;
  if (beam == 0 || beam + 1 >= scan.ranges_m.size() || !scan.valid(beam - 1) ||
      !scan.valid(beam + 1))
    return along_range;
  const Vec3 tangent = (T_C_L.linear() * (scan.point_L(beam + 1) - scan.point_L(beam - 1)));
  if (!(tangent.norm() > 1e-9)) return along_range;
  if (camera_height_m && isGroundBeam(p_C, up_C, *camera_height_m)) return std::nullopt;
  Vec3 n = tangent.cross(up_C);
  if (!(n.norm() > 1e-9 * tangent.norm())) return along_range;
  n.normalize();
  const double nb = n.dot(b_c);
  if (std::abs(nb) < 0.1) return along_range;  // grazing: the intersection is ill-conditioned
  const Vec3 X = b_c * (n.dot(p_C) / nb);
  if (!(X.norm() > 0.7 * p_C.norm() && X.norm() < 1.3 * p_C.norm())) return std::nullopt;
  return X;
}

// Gate against the median, then a Huber mean around it.
std::optional<ScaleEstimate> robustScale(const std::vector<double>& samples,
                                         const LidarScaleOptions& options) {
  const int min_n = std::max(options.min_associations, 1);
  if (static_cast<int>(samples.size()) < min_n) return std::nullopt;
  const double m = median(samples);
  std::vector<double> kept;
  for (const double s : samples)
    if (std::abs(s - m) <= options.gate_relative * m) kept.push_back(s);
  if (static_cast<int>(kept.size()) < min_n) return std::nullopt;

  double mu = median(kept);
  std::vector<double> abs_dev(kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) abs_dev[i] = std::abs(kept[i] - mu);
  const double sigma = 1.4826 * median(abs_dev);
  const double threshold = std::max(options.huber_k * sigma, 1e-9 * mu);
  for (int iter = 0; iter < 10; ++iter) {
    double sum_w = 0.0, sum_ws = 0.0;
    for (const double s : kept) {
      const double r = std::abs(s - mu);
      const double w = r <= threshold ? 1.0 : threshold / r;
      sum_w += w;
      sum_ws += w * s;
    }
    const double mu_next = sum_ws / sum_w;
    const bool converged = std::abs(mu_next - mu) <= 1e-12 * mu;
    mu = mu_next;
    if (converged) break;
  }

  ScaleEstimate estimate;
  estimate.scale = mu;
  estimate.associations = static_cast<int>(kept.size());
  estimate.rejected = static_cast<int>(samples.size() - kept.size());
  estimate.spread = sigma;
  return estimate;
}

// Associates each scan end point (projected with T_C_L into cam) with the nearest usable pixel
// within the radius, keeps one scan point per pixel (the closest in the image), turns it into a
// sample with sample_of(index, p_C) and returns the gated Huber mean of the samples.
template <typename SampleFn>
std::optional<ScaleEstimate> associateAndEstimate(const LidarScan& scan, const SE3& T_C_L,
                                                  const camera::Camera& cam,
                                                  const std::vector<ScaleFeature>& features,
                                                  const std::vector<bool>& usable,
                                                  const LidarScaleOptions& options,
                                                  const SampleFn& sample_of) {
  const double radius_px = options.association_radius_px;
  const FeatureGrid grid(features, usable, std::max(radius_px, 1.0));

  // Per feature: the closest scan point in the image (squared px distance) and its sample.
  constexpr double kNone = std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, std::optional<double>>> best(features.size(), {kNone, {}});
  std::visit(
      [&](const auto& model) {
        for (std::size_t b = 0; b < scan.ranges_m.size(); ++b) {
          if (!scan.valid(b) || onDepthEdge(scan, b, options.edge_relative)) continue;
          const Vec3 p_C = T_C_L * scan.point_L(b);
          if (!(p_C.norm() > options.min_range_m)) continue;
          const std::optional<Vec2> px = model.project(p_C);
          if (!px || !model.isValid(*px)) continue;
          const auto hit = grid.nearest(*px, radius_px);
          if (!hit) continue;
          auto& [d2, sample] = best[hit->first];
          if (hit->second < d2) {
            d2 = hit->second;
            sample = sample_of(hit->first, p_C, b);
          }
        }
      },
      cam);

  std::vector<double> samples;
  for (const auto& [d2, sample] : best)
    if (sample && std::isfinite(*sample) && *sample > 0.0) samples.push_back(*sample);
  return robustScale(samples, options);
}

}  // namespace

std::optional<ScaleEstimate> estimateLidarScale(const LidarScan& scan, const SE3& T_C_L,
                                                const camera::Camera& cam,
                                                const std::vector<ScaleFeature>& features,
                                                const LidarScaleOptions& options) {
  if (features.empty() || scan.ranges_m.empty() || !allFinite(T_C_L)) return std::nullopt;
  std::vector<bool> usable(features.size(), false);
  std::vector<double> unit_range(features.size(), 0.0);
  for (std::size_t i = 0; i < features.size(); ++i) {
    const ScaleFeature& f = features[i];
    unit_range[i] = f.p_C_unit.norm();
    usable[i] = f.px.allFinite() && f.p_C_unit.allFinite() && unit_range[i] > 1e-12;
  }
  // s_i = |p_C| / |X_unit|
  return associateAndEstimate(
      scan, T_C_L, cam, features, usable, options,
      [&](std::size_t i, const Vec3& p_C, std::size_t) -> std::optional<double> {
        return p_C.norm() / unit_range[i];
      });
}

std::optional<ScaleEstimate> estimateLidarScaleCorrection(
    const LidarScan& scan, const SE3& T_C_L, const camera::Camera& cam,
    const std::vector<TrackScaleFeature>& features, const Vec3& up_C,
    std::optional<double> camera_height_m, const LidarScaleOptions& options) {
  if (features.empty() || scan.ranges_m.empty() || !allFinite(T_C_L)) return std::nullopt;
  std::vector<ScaleFeature> pixels(features.size());
  std::vector<bool> usable(features.size(), false);
  for (std::size_t i = 0; i < features.size(); ++i) {
    const TrackScaleFeature& f = features[i];
    pixels[i].px = f.px;
    usable[i] = f.px.allFinite() && f.bearing_C.allFinite() && f.bearing_old_C.allFinite() &&
                f.R_old_cur.allFinite() && f.t_old_cur.allFinite() && f.t_old_cur.norm() > 1e-9;
  }
  const double min_sin_parallax = std::sin(options.min_parallax_deg * M_PI / 180.0);
  const Vec3 up = up_C.normalized();
  // kappa_i = -(b x t).(b x R X_C) / |b x t|^2, X_C on the feature's ray and the beam's surface
  return associateAndEstimate(
      scan, T_C_L, cam, pixels, usable, options,
      [&](std::size_t i, const Vec3& p_C, std::size_t beam) -> std::optional<double> {
        const TrackScaleFeature& f = features[i];
        const auto X_C =
            onBeamSurface(scan, T_C_L, beam, p_C, f.bearing_C.normalized(), up, camera_height_m);
        if (!X_C) return std::nullopt;
        const Vec3 b = f.bearing_old_C.normalized();
        const Vec3 Rp = f.R_old_cur * *X_C;
        if (b.cross(Rp.normalized()).norm() < min_sin_parallax) return std::nullopt;
        const Vec3 bxt = b.cross(f.t_old_cur);
        const double bxt2 = bxt.squaredNorm();
        if (!(bxt2 > 1e-12)) return std::nullopt;
        return -bxt.dot(b.cross(Rp)) / bxt2;
      });
}

}  // namespace ovo::estimator
