// Two-view geometry: the 2-point translation with a known rotation, triangulation, parallax.
#include "estimator/common/two_view.hpp"

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>

#include "frontend/triangulation.hpp"

namespace ovo::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

/// Angle between the observed b1 and the epipolar plane of (t, R b0).
double epipolarError(const Vec3& t, const Vec3& Rb0, const Vec3& b1) {
  const Vec3 m = t.cross(Rb0);
  const double n = m.norm();
  if (n < 1e-12) return M_PI;
  return std::abs(m.dot(b1)) / n;
}

}  // namespace

double medianParallaxDeg(const std::vector<Vec3>& bearings0_C, const std::vector<Vec3>& bearings1_C,
                         const Mat3& R_C1_C0) {
  std::vector<double> angles;
  angles.reserve(bearings0_C.size());
  for (std::size_t i = 0; i < bearings0_C.size(); ++i) {
    const double c = std::clamp((R_C1_C0 * bearings0_C[i]).dot(bearings1_C[i]), -1.0, 1.0);
    angles.push_back(std::acos(c));
  }
  if (angles.empty()) return 0.0;
  auto mid = angles.begin() + static_cast<long>(angles.size() / 2);
  std::nth_element(angles.begin(), mid, angles.end());
  return *mid / kDegToRad;
}

TwoViewResult triangulateTwoView(const std::vector<Vec3>& bearings0_C,
                                 const std::vector<Vec3>& bearings1_C, const Mat3& R_C1_C0,
                                 const Vec3& t_C1_C0, const std::vector<std::uint8_t>* inliers,
                                 double min_parallax_deg) {
  TwoViewResult out;
  out.R_C1_C0 = R_C1_C0;
  out.t_C1_C0 = t_C1_C0;
  const double cos_min = std::cos(min_parallax_deg * kDegToRad);
  for (std::size_t i = 0; i < bearings0_C.size(); ++i) {
    if (inliers != nullptr && !(*inliers)[i]) continue;
    if ((R_C1_C0 * bearings0_C[i]).dot(bearings1_C[i]) > cos_min) continue;
    const auto p = frontend::triangulateMidpoint(R_C1_C0, t_C1_C0, bearings0_C[i], bearings1_C[i]);
    if (!p || !(p->depth_prev > 0.0) || !(p->depth_cur > 0.0)) continue;
    out.points_index.push_back(static_cast<int>(i));
    out.p_C0.push_back(p->depth_prev * bearings0_C[i]);
    out.depth0.push_back(p->depth_prev);
  }
  return out;
}

std::optional<TwoViewResult> twoViewKnownRotation(const std::vector<Vec3>& bearings0_C,
                                                  const std::vector<Vec3>& bearings1_C,
                                                  const Mat3& R_C1_C0,
                                                  const TwoViewOptions& options) {
  const int n = static_cast<int>(bearings0_C.size());
  if (n < std::max(2, options.min_points)) return std::nullopt;
  std::vector<Vec3> Rb0(n), normals(n);
  for (int i = 0; i < n; ++i) {
    Rb0[i] = R_C1_C0 * bearings0_C[i];
    normals[i] = Rb0[i].cross(bearings1_C[i]);
  }
  // Reproducible sampling (SplitMix64 per hypothesis).
  auto draw = [seed = options.seed](std::uint64_t k, int m) {
    std::uint64_t z = seed + 0x9E3779B97F4A7C15ULL * (k + 1);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    return static_cast<int>(z % static_cast<std::uint64_t>(m));
  };
  int best_count = -1;
  Vec3 best_t = Vec3::UnitZ();
  for (int k = 0; k < options.ransac_iterations; ++k) {
    const int i = draw(2 * static_cast<std::uint64_t>(k), n);
    const int j = draw(2 * static_cast<std::uint64_t>(k) + 1, n);
    if (i == j) continue;
    Vec3 t = normals[i].cross(normals[j]);
    if (t.norm() < 1e-12) continue;
    t.normalize();
    int count = 0;
    for (int m = 0; m < n; ++m)
      count += epipolarError(t, Rb0[m], bearings1_C[m]) < options.inlier_rad;
    if (count > best_count) {
      best_count = count;
      best_t = t;
    }
  }
  if (best_count < options.min_points) return std::nullopt;
  // Least-squares refit: t = smallest right singular vector of the stacked unit normals.
  std::vector<std::uint8_t> inliers(n, 0);
  Eigen::MatrixXd A(best_count, 3);
  int row = 0;
  for (int m = 0; m < n; ++m) {
    if (epipolarError(best_t, Rb0[m], bearings1_C[m]) < options.inlier_rad && row < best_count) {
      inliers[m] = 1;
      const double norm = normals[m].norm();
      A.row(row++) = (norm > 1e-12 ? Vec3(normals[m] / norm) : Vec3::Zero()).transpose();
    }
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A.topRows(row), Eigen::ComputeFullV);
  Vec3 t = svd.matrixV().col(2);
  if (t.dot(best_t) < 0.0) t = -t;
  // Cheirality: the sign with more points in front of both cameras.
  TwoViewResult plus =
      triangulateTwoView(bearings0_C, bearings1_C, R_C1_C0, t, &inliers, options.min_parallax_deg);
  TwoViewResult minus =
      triangulateTwoView(bearings0_C, bearings1_C, R_C1_C0, -t, &inliers, options.min_parallax_deg);
  TwoViewResult& best = plus.p_C0.size() >= minus.p_C0.size() ? plus : minus;
  if (static_cast<int>(best.p_C0.size()) < options.min_points) return std::nullopt;
  return best;
}

}  // namespace ovo::estimator
