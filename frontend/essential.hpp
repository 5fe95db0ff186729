// Essential matrix on bearing vectors (DESIGN section 4): 8-point solvers, projection onto the
// essential manifold, the error on the sphere, the four-fold decomposition with cheirality on
// triangulated points, rotation-only (Kabsch) fit and Gauss-Newton refinement on the sphere.
// Convention: X_cur = R_cur_prev X_prev + t_cur_prev, E = [t_cur_prev]x R_cur_prev,
// b_cur^T E b_prev = 0.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <vector>

#include "common/types.hpp"

namespace ovo::frontend {

/// Runs fn(begin, end) over sub-ranges covering [0, n), possibly on several threads
/// (gpu::ScoringBackend::parallelFor).
using ParallelFor = std::function<void(int n, const std::function<void(int, int)>& fn)>;

/// A relative motion between two camera frames; t has unit length (or is zero).
struct RelativeMotion {
  Mat3 R_cur_prev = Mat3::Identity();
  Vec3 t_cur_prev = Vec3::Zero();
};

/// E = [t]x R.
Mat3 essentialFromMotion(const Mat3& R_cur_prev, const Vec3& t_cur_prev);

/// Minimal 8-point solve: the null vector of the 8x9 system A_i = kron(b_cur_i, b_prev_i) by
/// Householder QR (a rank-deficient sample, e.g. pure rotation, still gives one null vector),
/// projected to an essential matrix; exactly the RANSAC hypotheses' solver
/// (gpu::eightPointLanes). nullopt for non-finite input or a result of rank < 2.
std::optional<Mat3> eightPointMinimal(const std::array<Vec3, 8>& b_prev,
                                      const std::array<Vec3, 8>& b_cur);

/// Least-squares 8-point on the matches with flag != 0 (all when flags is empty): the last right
/// singular vector of A (via QR of A then SVD of the 9x9 R), projected to an essential matrix.
/// nullopt with fewer than 8 matches or non-finite values.
std::optional<Mat3> eightPoint(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                               const std::vector<std::uint8_t>& flags = {});

/// Closest essential matrix (Frobenius): singular values (1, 1, 0). nullopt when rank < 2.
std::optional<Mat3> projectToEssential(const Mat3& E);

/// The error on the sphere (a squared angle, rad^2):
///   (b_c^T E b_p)^2 / (|(I - b_c b_c^T) E b_p|^2 + |(I - b_p b_p^T) E^T b_c|^2);
/// to first order the squared angular correction, split over both bearings, that puts the match
/// on the epipolar constraint. Unit bearings expected. Infinity when the denominator is zero.
double sphereError(const Mat3& E, const Vec3& b_prev, const Vec3& b_cur);

/// The four (R, t) with E ~ [t]x R (Hartley-Zisserman 9.6.2): (R1, +u3), (R1, -u3), (R2, +u3),
/// (R2, -u3), R_i proper rotations, t unit.
std::array<RelativeMotion, 4> decomposeEssential(const Mat3& E);

/// Picks among the four decompositions the one with the most flagged matches triangulated with
/// positive depth along BOTH bearings (pairs without parallax are skipped; at most 300 matches,
/// evenly spread over the flagged ones, vote). nullopt when no candidate has a positive point.
/// *num_positive gets the winner's count. parallel_for (optional) spreads the four candidates
/// over threads; the result does not depend on it.
std::optional<RelativeMotion> selectByCheirality(const Mat3& E, const std::vector<Vec3>& b_prev,
                                                 const std::vector<Vec3>& b_cur,
                                                 const std::vector<std::uint8_t>& flags,
                                                 int* num_positive = nullptr,
                                                 const ParallelFor& parallel_for = {});

/// Rotation that best maps flagged b_prev onto b_cur (Kabsch / orthogonal Procrustes on the
/// sphere: minimises sum |b_cur - R b_prev|^2). nullopt with fewer than 2 flagged matches.
std::optional<Mat3> rotationOnly(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                                 const std::vector<std::uint8_t>& flags);

/// Refines (R, t) on the flagged matches by Levenberg-Marquardt on the sphere error e_i,
/// R <- R Exp(w), t <- normalise(t + B dt) with B a tangent basis at t (5 degrees of freedom).
/// cauchy_scale_rad > 0 minimises sum c^2 log(1 + e_i / c^2) (c = cauchy_scale_rad) instead of
/// sum e_i, so a wrong match just inside the inlier threshold cannot bend the model. Returns the
/// refined motion (the input when no step lowers the cost).
/// parallel_for (optional) spreads the per-match sums over threads; they are reduced in fixed
/// chunks in a fixed order, so the result is the same bits with or without it.
RelativeMotion refineOnSphere(const RelativeMotion& init, const std::vector<Vec3>& b_prev,
                              const std::vector<Vec3>& b_cur,
                              const std::vector<std::uint8_t>& flags, int max_iterations = 10,
                              double cauchy_scale_rad = 0.0, const ParallelFor& parallel_for = {});

}  // namespace ovo::frontend
