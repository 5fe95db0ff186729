#include "frontend/ransac.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "frontend/essential.hpp"
#include "gpu/hypotheses.hpp"

namespace ovo::frontend {
std::array<int, 8> sampleIndices(std::uint64_t seed, std::uint64_t k, int num_matches) {
  return gpu::sampleIndices(seed, k, num_matches);
}

double requiredIterations(double inlier_ratio, double confidence) {
  const double p_good = std::pow(std::clamp(inlier_ratio, 0.0, 1.0), 8);
  if (p_good >= 1.0) return 1.0;
  if (p_good <= 0.0) return std::numeric_limits<double>::infinity();
  return std::log(1.0 - std::clamp(confidence, 0.0, 1.0 - 1e-15)) / std::log1p(-p_good);
}

Ransac::Ransac(std::unique_ptr<gpu::ScoringBackend> backend) : backend_(std::move(backend)) {}
Ransac::~Ransac() = default;

RansacResult Ransac::run(const std::vector<Vec3>& b_prev, const std::vector<Vec3>& b_cur,
                         const RansacOptions& options) {
  RansacResult result;
  counts_.clear();
  const int n = static_cast<int>(std::min(b_prev.size(), b_cur.size()));
  result.inliers.assign(n, 0);
  if (n < 8 || options.max_iterations <= 0) return result;

  prev_soa_.resize(3 * static_cast<std::size_t>(n));
  cur_soa_.resize(3 * static_cast<std::size_t>(n));
  prev_soa_d_.resize(3 * static_cast<std::size_t>(n));
  cur_soa_d_.resize(3 * static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      const std::size_t at = static_cast<std::size_t>(r) * n + i;
      prev_soa_d_[at] = b_prev[i](r);
      cur_soa_d_[at] = b_cur[i](r);
      prev_soa_[at] = static_cast<float>(b_prev[i](r));
      cur_soa_[at] = static_cast<float>(b_cur[i](r));
    }
  const gpu::BearingsSoA bearings{prev_soa_d_.data(), cur_soa_d_.data(), n};
  const gpu::MatchesSoA matches{prev_soa_.data(), cur_soa_.data(), n};
  backend_->setMatches(matches, bearings);
  const float k = gpu::inlierConstant(options.inlier_threshold_rad);

  const int total = options.max_iterations;
  const int block = options.adaptive ? std::max(1, options.block_size) : total;
  counts_.assign(total, 0);
  int best = -1, best_count = 0, evaluated = 0;
  while (evaluated < total) {
    const int h0 = evaluated, h1 = std::min(total, evaluated + block);
    // Hypothesis h depends on (seed, h) only: the same bits on every backend and thread.
    backend_->generateAndScore(options.seed, h0, h1, k, &counts_[h0]);
    for (int h = h0; h < h1; ++h)
      if (counts_[h] > best_count) {  // strict: ties keep the lowest index
        best_count = counts_[h];
        best = h;
      }
    evaluated = h1;
    if (options.adaptive && best_count > 0 &&
        evaluated >= requiredIterations(static_cast<double>(best_count) / n, options.confidence))
      break;
  }
  counts_.resize(evaluated);
  result.iterations = evaluated;
  if (best < 0) return result;

  float E_best[9];
  gpu::generateHypothesesCpu(bearings, options.seed, best, best + 1, E_best);
  gpu::inlierFlagsCpu(E_best, matches, k, result.inliers.data());
  result.found = true;
  result.best_hypothesis = best;
  result.num_inliers = best_count;
  std::array<Vec3, 8> sp, sc;
  const auto idx = sampleIndices(options.seed, static_cast<std::uint64_t>(best), n);
  for (int j = 0; j < 8; ++j) {
    sp[j] = b_prev[idx[j]];
    sc[j] = b_cur[idx[j]];
  }
  result.E = eightPointMinimal(sp, sc).value_or(Mat3::Zero());  // the double-precision winner
  return result;
}

}  // namespace ovo::frontend
