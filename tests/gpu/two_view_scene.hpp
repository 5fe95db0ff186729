// Synthetic two-view bearing problems with known answers (shared by the geometry tests and
// bench/bench_ransac.cpp): random points seen by a wide-angle (fisheye-like) camera, bearings up
// to max_off_axis_deg off the optical axis (beyond 90: z < 0), angular noise, random outliers.
#pragma once

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "common/so3.hpp"
#include "common/types.hpp"
#include "gpu/hypotheses.hpp"

namespace ovo::test {

struct TwoViewSceneOptions {
  int num_matches = 1000;
  double outlier_ratio = 0.3;
  double noise_px = 0.5;            // per tangent axis, per bearing
  double px_per_rad = 305.0;        // RoMoVi fisheye near its centre
  double max_off_axis_deg = 100.0;  // both views
  double min_depth_m = 2.0, max_depth_m = 20.0;
  Mat3 R_cur_prev = so3::exp(Vec3(0.02, -0.08, 0.03));
  Vec3 t_cur_prev = Vec3(0.15, -0.05, -0.5);  // metres (X_cur = R X_prev + t)
  std::uint64_t seed = 7;
};

struct TwoViewScene {
  Mat3 R_cur_prev;
  Vec3 t_cur_prev;  // as given (not unit)
  std::vector<Vec3> b_prev, b_cur;
  std::vector<std::uint8_t> is_outlier;
};

inline Vec3 randomDirectionInCap(std::mt19937_64& rng, double max_off_axis_rad) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double cos_max = std::cos(max_off_axis_rad);
  const double z = cos_max + (1.0 - cos_max) * u(rng);  // uniform on the cap
  const double phi = 2.0 * M_PI * u(rng);
  const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return Vec3(r * std::cos(phi), r * std::sin(phi), z);
}

inline Vec3 perturbBearing(std::mt19937_64& rng, const Vec3& b, double sigma_rad) {
  if (sigma_rad <= 0.0) return b;
  std::normal_distribution<double> g(0.0, sigma_rad);
  const Vec3 helper = std::abs(b.x()) < 0.9 ? Vec3::UnitX() : Vec3::UnitY();
  const Vec3 e1 = b.cross(helper).normalized(), e2 = b.cross(e1);
  // Sequenced draws, the last component first (see draw3 in tests/test_support.hpp).
  const double n2 = g(rng), n1 = g(rng);
  return (b + n1 * e1 + n2 * e2).normalized();
}

inline TwoViewScene makeTwoViewScene(const TwoViewSceneOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double max_rad = o.max_off_axis_deg * M_PI / 180.0;
  const double sigma = o.noise_px / o.px_per_rad;
  TwoViewScene s{o.R_cur_prev, o.t_cur_prev, {}, {}, {}};
  const int num_outliers = static_cast<int>(std::lround(o.outlier_ratio * o.num_matches));
  while (static_cast<int>(s.b_prev.size()) < o.num_matches) {
    const Vec3 dir_P = randomDirectionInCap(rng, max_rad);
    const double depth = o.min_depth_m + (o.max_depth_m - o.min_depth_m) * u(rng);
    const Vec3 p_C = o.R_cur_prev * (depth * dir_P) + o.t_cur_prev;
    const Vec3 b_C = p_C.normalized();
    if (std::acos(std::clamp(b_C.z(), -1.0, 1.0)) > max_rad) continue;
    s.b_prev.push_back(perturbBearing(rng, dir_P, sigma));
    s.b_cur.push_back(perturbBearing(rng, b_C, sigma));
    s.is_outlier.push_back(0);
  }
  // Outliers: the current bearing replaced by an unrelated direction, spread over the matches.
  for (int j = 0; j < num_outliers; ++j) {
    const int i =
        static_cast<int>((static_cast<long>(j) * o.num_matches) / std::max(1, num_outliers));
    s.b_cur[i] = randomDirectionInCap(rng, max_rad);
    s.is_outlier[i] = 1;
  }
  return s;
}

/// The scene's bearings as rows of x, y, z (structure of arrays), for gpu::BearingsSoA.
struct SoAd {
  std::vector<double> prev, cur;
  gpu::BearingsSoA view() const {
    return {prev.data(), cur.data(), static_cast<int>(prev.size() / 3)};
  }
};

inline SoAd toSoAd(const TwoViewScene& s) {
  const std::size_t n = s.b_prev.size();
  SoAd out{std::vector<double>(3 * n), std::vector<double>(3 * n)};
  for (std::size_t i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      out.prev[r * n + i] = s.b_prev[i](r);
      out.cur[r * n + i] = s.b_cur[i](r);
    }
  return out;
}

}  // namespace ovo::test
