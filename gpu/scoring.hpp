// RANSAC scoring backends (DESIGN section 5): count, for many essential-matrix hypotheses, the
// bearing matches whose error on the sphere is below a threshold. Plain float arrays only, so the
// frontend's RANSAC driver can use any backend; every backend returns bit-identical counts.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>

#include "gpu/hypotheses.hpp"

namespace ovo::gpu {

/// The inlier test shared bit-for-bit by every backend, for E (3x3) and unit bearings b_p, b_c:
///   a = E b_p, c = E^T b_c, num = b_c . a, s = |a|^2 + |c|^2,
///   inlier  <=>  num^2 < k s   with  k = thr^2 / (1 + 2 thr^2).
/// This is the sphere Sampson error num^2 / (|(I - b_c b_c^T) a|^2 + |(I - b_p b_p^T) c|^2)
/// < thr^2, because both projections remove exactly num^2 from |a|^2 and |c|^2. Float, no
/// division; sums in a fixed order, with fused multiply-adds exactly where the CPU kernel uses
/// them (see cpuScoringUsesFma()); E = 0 and zero bearings are never inliers.
float inlierConstant(double threshold_rad);

/// Bearing matches in structure-of-arrays float layout: prev = [x_0..x_{n-1}, y_0.., z_0..],
/// cur likewise (3 n floats each). The arrays must stay alive while a backend uses them.
struct MatchesSoA {
  const float* prev = nullptr;
  const float* cur = nullptr;
  int n = 0;
};

/// CPU kernel (gpu/score_simd.cpp, vectorised over matches): counts[h - h_begin] = inliers of
/// hypothesis h for h in [h_begin, h_end); E holds 9 row-major floats per hypothesis.
void scoreHypothesesCpu(const float* E, int h_begin, int h_end, const MatchesSoA& m, float k,
                        int* counts);
/// Inlier flags (0/1) of one hypothesis E9 with the same arithmetic as the counts.
void inlierFlagsCpu(const float* E9, const MatchesSoA& m, float k, std::uint8_t* flags);
/// Hypotheses per generate-then-score step of the CPU backends: their 9 floats stay in L1.
inline constexpr int kFusedChunk = 32;
/// generateHypothesesCpu then scoreHypothesesCpu over [h_begin, h_end), kFusedChunk at a time:
/// counts[h - h_begin] = inliers of hypothesis h for `seed`.
void generateAndScoreCpu(const BearingsSoA& bearings, const MatchesSoA& matches, std::uint64_t seed,
                         int h_begin, int h_end, float k, int* counts);
/// True when the CPU kernel was compiled with hardware FMA; the OpenCL kernel is built to match.
bool cpuScoringUsesFma();

/// A RANSAC backend: matches are set once per frame, then hypotheses are generated and scored in
/// blocks. Hypothesis h is generateHypothesesCpu's hypothesis h for the seed, bit for bit, on
/// every backend.
class ScoringBackend {
 public:
  virtual ~ScoringBackend() = default;
  /// "serial", "threads" or "opencl".
  virtual std::string_view name() const = 0;
  /// Uploads (or references) the matches used by the following calls: float bearings for the
  /// scoring and, for generateAndScore() and generate(), the same bearings in double.
  virtual void setMatches(const MatchesSoA& matches, const BearingsSoA& bearings) = 0;
  /// Matches for score() only.
  void setMatches(const MatchesSoA& matches) { setMatches(matches, BearingsSoA{}); }
  /// inlier_counts[h] for the num_hypotheses hypotheses in E_rowmajor (9 floats each).
  virtual void score(const float* E_rowmajor, int num_hypotheses, float k, int* inlier_counts) = 0;
  /// Generates hypotheses [h_begin, h_end) for `seed` and scores them:
  /// inlier_counts[h - h_begin]. The hot loop of RANSAC: serial generates and scores chunks that
  /// stay in L1, threads spreads the chunks over the pool, opencl runs both as device kernels.
  virtual void generateAndScore(std::uint64_t seed, int h_begin, int h_end, float k,
                                int* inlier_counts) = 0;
  /// Hypotheses [h_begin, h_end) as this backend generates them: 9 row-major floats each.
  virtual void generate(std::uint64_t seed, int h_begin, int h_end, float* E_rowmajor) = 0;
  /// Runs fn(begin, end) over sub-ranges covering [0, n): on the thread pool when the backend may
  /// use it (threads, opencl), else inline.
  virtual void parallelFor(int n, const std::function<void(int, int)>& fn);
};

/// Makes a backend: "serial", "threads", "opencl" or "auto" (opencl when a device is found, else
/// threads with one warning per process). Throws ovo::Error for an unknown name, or for "opencl"
/// when no OpenCL device is usable or the kernel does not build.
std::unique_ptr<ScoringBackend> makeScoringBackend(std::string_view name);

std::unique_ptr<ScoringBackend> makeSerialBackend();
std::unique_ptr<ScoringBackend> makeThreadsBackend();
/// Throws ovo::Error when no OpenCL device is usable.
std::unique_ptr<ScoringBackend> makeOpenClBackend();

}  // namespace ovo::gpu
