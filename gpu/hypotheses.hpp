// RANSAC hypothesis generation (DESIGN sections 4, 5): reproducible 8-samples and a batched,
// branch-free minimal 8-point solve on bearings, vectorised across hypotheses. Plain arrays only
// (gpu/hypotheses_simd.cpp is built with -march=native and without FMA contraction), so the same
// hypothesis gets the same bits whichever thread, batch or backend computes it;
// gpu/kernels/ransac_hypotheses.cl is the same solver, operation for operation, on the device.
#pragma once

#include <array>
#include <cstdint>

namespace ovo::gpu {

/// Hypotheses solved together in SIMD lanes.
inline constexpr int kEightPointLanes = 8;

/// Bearing matches in double structure-of-arrays layout: prev = [x_0..x_{n-1}, y.., z..], cur
/// likewise. Unit or zero bearings.
struct BearingsSoA {
  const double* prev = nullptr;
  const double* cur = nullptr;
  int n = 0;
};

/// The 8 distinct match indices of hypothesis k: splitmix64 stream keyed by (seed, k)
/// (Steele, Lea, Flood 2014), Lemire's multiply-shift to [0, n). Requires n >= 8.
std::array<int, 8> sampleIndices(std::uint64_t seed, std::uint64_t k, int num_matches);

/// Minimal 8-point solves for kEightPointLanes samples at once. Sample l's j-th match is
/// (prev[j][r][l], cur[j][r][l]), r = x, y, z. For each lane: the null vector of the 8x9 system
/// A_i = kron(b_cur_i, b_prev_i) by Householder QR of A^T (the last column of Q; rank-deficient
/// samples such as pure rotation still give a null vector), reshaped row-major to E and projected
/// to singular values (1, 1, 0) through a cyclic Jacobi eigen-decomposition of E^T E:
/// E_hat = sum_{i=1,2} (E v_i / |E v_i|) v_i^T over its two largest eigenvectors.
/// E_out[j][l] = entry j (row-major) of lane l's E_hat; all zero (valid[l] = false) when the
/// input is not finite or E has rank < 2.
void eightPointLanes(const double prev[8][3][kEightPointLanes],
                     const double cur[8][3][kEightPointLanes], double E_out[9][kEightPointLanes],
                     bool valid[kEightPointLanes]);

/// Hypotheses h in [h_begin, h_end): sample (seed, h), solve, store as 9 row-major floats at
/// E_rowmajor + 9 (h - h_begin) (zeros for a failed solve, which never count an inlier).
void generateHypothesesCpu(const BearingsSoA& m, std::uint64_t seed, int h_begin, int h_end,
                           float* E_rowmajor);

}  // namespace ovo::gpu
