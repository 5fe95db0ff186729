// Two-view geometry on bearings, for the window's start and ground chain and the kf's parallax
// test: with the rotation known (from the gyro) the translation direction from a 2-point RANSAC
// on the epipolar constraint, the inliers triangulated at unit baseline, and the
// rotation-compensated parallax between two views. (Without a known rotation the frontend's
// 8-point RANSAC gives both.)
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "common/types.hpp"
#include "frontend/relative_pose.hpp"

namespace ovo::estimator {

struct TwoViewOptions {
  int ransac_iterations = 200;
  double inlier_rad = 2e-3;       // epipolar-plane angle threshold, rad
  double min_parallax_deg = 1.0;  // per point triangulation angle
  int min_points = 20;
  std::uint64_t seed = 11;
};

/// The first two keyframes' geometry: X_1 = R_C1_C0 X_0 + t_C1_C0 with |t| = 1.
struct TwoViewResult {
  Mat3 R_C1_C0 = Mat3::Identity();
  Vec3 t_C1_C0 = Vec3::UnitZ();
  std::vector<int> points_index;  // index into the input bearings of each triangulated point
  std::vector<Vec3> p_C0;         // triangulated points at unit baseline, camera 0
  std::vector<double> depth0;     // distance along bearing 0 (unit baseline)
};

/// Translation direction with a known rotation: t . ((R b0) x b1) = 0 per match. 2-point RANSAC
/// (t = n_i x n_j), least-squares refit on the inliers, sign by cheirality; nullopt when too few
/// points triangulate in front of both cameras.
std::optional<TwoViewResult> twoViewKnownRotation(const std::vector<Vec3>& bearings0_C,
                                                  const std::vector<Vec3>& bearings1_C,
                                                  const Mat3& R_C1_C0,
                                                  const TwoViewOptions& options);

/// Triangulates the matches for a given (R, unit t); keeps points in front of both cameras with
/// at least min_parallax_deg between the rays.
TwoViewResult triangulateTwoView(const std::vector<Vec3>& bearings0_C,
                                 const std::vector<Vec3>& bearings1_C, const Mat3& R_C1_C0,
                                 const Vec3& t_C1_C0, const std::vector<std::uint8_t>* inliers,
                                 double min_parallax_deg);

/// Median angle (deg) between R_C1_C0 b0 and b1: the rotation-compensated parallax.
double medianParallaxDeg(const std::vector<Vec3>& bearings0_C, const std::vector<Vec3>& bearings1_C,
                         const Mat3& R_C1_C0);

}  // namespace ovo::estimator
