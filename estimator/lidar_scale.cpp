#include "estimator/lidar_scale.hpp"

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
  const double radius_px = options.association_radius_px;
  const FeatureGrid grid(features, usable, std::max(radius_px, 1.0));

  // Per feature: the closest scan point in the image (squared px distance) and its sample.
  constexpr double kNone = std::numeric_limits<double>::infinity();
  std::vector<std::pair<double, double>> best(features.size(), {kNone, 0.0});
  std::visit(
      [&](const auto& model) {
        for (std::size_t b = 0; b < scan.ranges_m.size(); ++b) {
          if (!scan.valid(b)) continue;
          const Vec3 p_C = T_C_L * scan.point_L(b);
          const double range_C = p_C.norm();
          if (!(range_C > options.min_range_m)) continue;
          const std::optional<Vec2> px = model.project(p_C);
          if (!px || !model.isValid(*px)) continue;
          const auto hit = grid.nearest(*px, radius_px);
          if (!hit) continue;
          auto& [d2, sample] = best[hit->first];
          if (hit->second < d2) {
            d2 = hit->second;
            sample = range_C / unit_range[hit->first];  // s_i = |p_C| / |X_unit|
          }
        }
      },
      cam);

  std::vector<double> samples;
  for (const auto& [d2, sample] : best)
    if (d2 != kNone && std::isfinite(sample) && sample > 0.0) samples.push_back(sample);
  const int min_n = std::max(options.min_associations, 1);
  if (static_cast<int>(samples.size()) < min_n) return std::nullopt;

  // Gate against the median, then a Huber mean around it.
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

}  // namespace ovo::estimator
