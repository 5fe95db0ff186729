// The ground-plane fit (RANSAC and least squares on unit-scale points) and its scale.
#include "estimator/common/ground_plane.hpp"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <random>

namespace ovo::estimator {

GroundPlaneOptions readGroundPlaneOptions(const Config& cfg) {
  GroundPlaneOptions o;
  o.max_normal_deviation_deg =
      cfg.getInRange("vo.ground.max_normal_deviation_deg", o.max_normal_deviation_deg, 0.0, 90.0);
  o.max_point_angle_from_down_deg = cfg.getInRange("vo.ground.max_point_angle_from_down_deg",
                                                   o.max_point_angle_from_down_deg, 1.0, 90.0);
  o.inlier_rel_threshold =
      cfg.getInRange("vo.ground.inlier_rel_threshold", o.inlier_rel_threshold, 1e-4, 1.0);
  o.ransac_iterations =
      cfg.getIntInRange("vo.ground.ransac_iterations", o.ransac_iterations, 1, 100000);
  o.min_inliers = cfg.getIntInRange("vo.ground.min_inliers", o.min_inliers, 3, 100000);
  return o;
}

namespace {

// Plane through the centroid with the smallest-eigenvalue normal; normal oriented along `up`.
std::optional<GroundPlane> leastSquaresPlane(const std::vector<Vec3>& pts, const Vec3& up) {
  if (pts.size() < 3) return std::nullopt;
  Vec3 c = Vec3::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  Mat3 S = Mat3::Zero();
  for (const auto& p : pts) S += (p - c) * (p - c).transpose();
  Eigen::SelfAdjointEigenSolver<Mat3> es(S);
  Vec3 n = es.eigenvectors().col(0);
  if (n.dot(up) < 0) n = -n;
  // Plane: n.X + d = 0 with the camera (origin) above it: d = -n.c > 0.
  const double d = -n.dot(c);
  if (!(d > 0) || !n.allFinite()) return std::nullopt;
  GroundPlane g;
  g.up_C = n;
  g.height = d;
  g.inliers = static_cast<int>(pts.size());
  return g;
}

}  // namespace

std::optional<GroundPlane> fitGroundPlane(const std::vector<Vec3>& points_C, const Vec3& up_prior_C,
                                          const GroundPlaneOptions& options) {
  const Vec3 up = up_prior_C.normalized();
  const double cos_point = std::cos(options.max_point_angle_from_down_deg * M_PI / 180.0);
  const double cos_normal = std::cos(options.max_normal_deviation_deg * M_PI / 180.0);

  std::vector<Vec3> cand;
  cand.reserve(points_C.size());
  for (const auto& p : points_C) {
    const double n = p.norm();
    if (!(n > 0) || !p.allFinite()) continue;
    if (-p.dot(up) / n >= cos_point) cand.push_back(p);  // below the camera
  }
  if (static_cast<int>(cand.size()) < options.min_inliers) return std::nullopt;

  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<std::size_t> pick(0, cand.size() - 1);
  std::vector<std::uint8_t> best_mask;
  int best_count = 0;
  for (int it = 0; it < options.ransac_iterations; ++it) {
    const std::size_t i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    Vec3 n = (cand[j] - cand[i]).cross(cand[k] - cand[i]);
    if (n.norm() < 1e-12) continue;
    n.normalize();
    if (n.dot(up) < 0) n = -n;
    if (n.dot(up) < cos_normal) continue;
    const double d = -n.dot(cand[i]);
    if (d <= 0) continue;
    int count = 0;
    std::vector<std::uint8_t> mask(cand.size(), 0);
    for (std::size_t m = 0; m < cand.size(); ++m) {
      if (std::abs(n.dot(cand[m]) + d) < options.inlier_rel_threshold * d) {
        mask[m] = 1;
        ++count;
      }
    }
    if (count > best_count) {
      best_count = count;
      best_mask = std::move(mask);
    }
  }
  if (best_count < options.min_inliers) return std::nullopt;

  std::vector<Vec3> inl;
  for (std::size_t m = 0; m < cand.size(); ++m)
    if (best_mask[m]) inl.push_back(cand[m]);
  auto plane = leastSquaresPlane(inl, up);
  if (!plane || plane->up_C.dot(up) < cos_normal) return std::nullopt;
  // One re-selection of inliers against the refined plane, then the final fit.
  std::vector<Vec3> inl2;
  for (const auto& p : cand)
    if (std::abs(plane->up_C.dot(p) + plane->height) < options.inlier_rel_threshold * plane->height)
      inl2.push_back(p);
  if (static_cast<int>(inl2.size()) >= options.min_inliers) {
    auto refined = leastSquaresPlane(inl2, up);
    if (refined && refined->up_C.dot(up) >= cos_normal) plane = refined;
  }
  if (plane->inliers < options.min_inliers) return std::nullopt;
  return plane;
}

}  // namespace ovo::estimator
