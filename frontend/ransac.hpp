// Reproducible essential-matrix RANSAC on bearing matches (DESIGN sections 4, 5). Hypothesis k
// draws its 8-sample from its own counter-based stream (seed, k) and is solved by the batched
// 8-point (gpu/hypotheses.hpp) with the same bits on any thread or device; the backend generates
// and scores, so every backend evaluates the same hypotheses and returns the same winner and
// inlier set.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string_view>
#include <vector>

#include "common/types.hpp"
#include "gpu/scoring.hpp"

namespace ovo::frontend {

struct RansacOptions {
  int max_iterations = 2000;           // hypotheses (upper bound when adaptive)
  bool adaptive = false;               // stop after the first block where `confidence` is reached
  double confidence = 0.999;           // P(at least one all-inlier sample), adaptive only
  double inlier_threshold_rad = 1e-3;  // on the sphere error's square root (an angle)
  std::uint64_t seed = 42;
  int block_size = 128;  // hypotheses per backend call when adaptive (the stopping granularity)
};

struct RansacResult {
  bool found = false;     // a hypothesis with at least one inlier
  Mat3 E = Mat3::Zero();  // the winning hypothesis (singular values (1, 1, 0))
  int best_hypothesis = -1;
  int num_inliers = 0;
  int iterations = 0;                 // hypotheses evaluated
  std::vector<std::uint8_t> inliers;  // of the winning hypothesis, float test of gpu/scoring.hpp
};

/// The 8 distinct match indices of hypothesis k (gpu::sampleIndices: splitmix64 keyed by (seed,
/// k)).
std::array<int, 8> sampleIndices(std::uint64_t seed, std::uint64_t k, int num_matches);

/// Number of hypotheses needed for `confidence` with inlier ratio w and 8-point samples.
double requiredIterations(double inlier_ratio, double confidence);

/// The RANSAC driver around one scoring backend; keeps its buffers across calls.
class Ransac {
 public:
  explicit Ransac(std::unique_ptr<gpu::ScoringBackend> backend);
  ~Ransac();

  /// Bearings must be unit (or zero for "no bearing": never an inlier). Fewer than 8 matches:
  /// not found.
  RansacResult run(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                   const RansacOptions& options);

  std::string_view backendName() const { return backend_->name(); }
  /// The backend's parallelFor (thread pool for threads and opencl, inline for serial).
  void parallelFor(int n, const std::function<void(int, int)>& fn) { backend_->parallelFor(n, fn); }
  /// Inlier counts of every hypothesis evaluated by the last run (index = hypothesis).
  const std::vector<int>& lastCounts() const { return counts_; }

 private:
  std::unique_ptr<gpu::ScoringBackend> backend_;
  std::vector<float> prev_soa_, cur_soa_;
  std::vector<double> prev_soa_d_, cur_soa_d_;
  std::vector<int> counts_;
};

}  // namespace ovo::frontend
