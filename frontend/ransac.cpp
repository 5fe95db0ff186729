#include "frontend/ransac.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "frontend/essential.hpp"

namespace ovo::frontend {
namespace {

// splitmix64 (Steele, Lea, Flood, "Fast splittable pseudorandom number generators", 2014).
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

}  // namespace

std::array<int, 8> sampleIndices(std::uint64_t seed, std::uint64_t k, int num_matches) {
  std::uint64_t key = seed;
  std::uint64_t state = splitmix64(key) ^ ((k + 1) * 0xD1B54A32D192ED03ull);
  std::array<int, 8> idx{};
  const auto n = static_cast<unsigned __int128>(num_matches);
  for (int j = 0; j < 8; ++j) {
    for (;;) {
      // Lemire's multiply-shift maps 64 random bits to [0, n).
      const int c = static_cast<int>((static_cast<unsigned __int128>(splitmix64(state)) * n) >> 64);
      if (std::find(idx.begin(), idx.begin() + j, c) == idx.begin() + j) {
        idx[j] = c;
        break;
      }
    }
  }
  return idx;
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
  for (int i = 0; i < n; ++i)
    for (int r = 0; r < 3; ++r) {
      prev_soa_[static_cast<std::size_t>(r) * n + i] = static_cast<float>(b_prev[i](r));
      cur_soa_[static_cast<std::size_t>(r) * n + i] = static_cast<float>(b_cur[i](r));
    }
  const gpu::MatchesSoA matches{prev_soa_.data(), cur_soa_.data(), n};
  backend_->setMatches(matches);
  const float k = gpu::inlierConstant(options.inlier_threshold_rad);

  const int total = options.max_iterations;
  const int block = options.adaptive ? std::max(1, options.block_size) : total;
  hypotheses_.resize(9 * static_cast<std::size_t>(total));
  counts_.assign(total, 0);
  int best = -1, best_count = 0, evaluated = 0;
  while (evaluated < total) {
    const int h0 = evaluated, h1 = std::min(total, evaluated + block);
    // Hypothesis h depends on (seed, h) only: generated on any thread, identical everywhere.
    backend_->parallelFor(h1 - h0, [&](int b, int e) {
      std::array<Vec3, 8> sp, sc;
      for (int h = h0 + b; h < h0 + e; ++h) {
        const auto idx = sampleIndices(options.seed, static_cast<std::uint64_t>(h), n);
        for (int j = 0; j < 8; ++j) {
          sp[j] = b_prev[idx[j]];
          sc[j] = b_cur[idx[j]];
        }
        const auto E = eightPointMinimal(sp, sc);
        float* out = &hypotheses_[9 * static_cast<std::size_t>(h)];
        for (int j = 0; j < 9; ++j) out[j] = E ? static_cast<float>((*E)(j / 3, j % 3)) : 0.0f;
      }
    });
    backend_->score(&hypotheses_[9 * static_cast<std::size_t>(h0)], h1 - h0, k, &counts_[h0]);
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

  const float* E_best = &hypotheses_[9 * static_cast<std::size_t>(best)];
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
