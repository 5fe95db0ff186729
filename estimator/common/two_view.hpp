// Two-view initialisation of the window (DESIGN section 7): with the rotation known from the
// gyro, the translation direction comes from a 2-point RANSAC on the epipolar constraint; without
// it, from the frontend's 8-point RANSAC. Inlier tracks are triangulated at unit baseline.
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

/// The initialisation's metric scale from LiDAR range ratios (beam range over the unit-baseline
/// distance of the track it lands next to). Ratios are grouped by agreement within 20 %: the
/// largest group wins unless a group at least half its size disagrees with it (beams through a
/// canopy gap onto the next row give a consistent wrong ratio), or the ground plane's scale
/// disagrees with it (beams that pass under a canopy's lower edge land next to the canopy's
/// features and agree with each other on a ratio several times too large; with a narrow camera
/// they can outnumber the beams on the ground). The ground plane settles such a tie with the
/// largest group it agrees with, of at least half the largest's size or min_associations / 2;
/// otherwise the tie is put off while allowed, then the ground plane's own scale is taken when
/// there is one (the LiDAR is overruled), else the nearest surfaces (smallest ratio: a gap only
/// reads too far).
struct LidarScaleVote {
  enum class Outcome {
    kAgreed,         // the largest group, unchallenged
    kGroundSettled,  // a tie settled by the ground plane
    kPutOff,         // a tie: wait for a later frame
    kForced,         // a tie that could not wait, without a ground plane: the nearest surfaces
    kOverruled,      // a tie that could not wait, no group agreeing with the ground plane: no
                     // LiDAR scale, the ground plane's is to be used
    kTooFew,         // too few ratios, or no group big enough: no LiDAR scale
  };
  Outcome outcome = Outcome::kTooFew;
  std::optional<double> scale;  // the chosen group's median ratio (kAgreed, kGroundSettled,
                                // kForced)
};
LidarScaleVote voteLidarScale(std::vector<double> ratios, std::optional<double> ground_scale,
                              int min_associations, bool can_put_off);

/// Median angle (deg) between R_C1_C0 b0 and b1: the rotation-compensated parallax.
double medianParallaxDeg(const std::vector<Vec3>& bearings0_C, const std::vector<Vec3>& bearings1_C,
                         const Mat3& R_C1_C0);

}  // namespace ovo::estimator
