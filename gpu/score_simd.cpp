// The CPU RANSAC scoring kernel: matches in SIMD lanes, the 9 entries of E broadcast. Built with
// -march=native and -ffp-contract=off (top CMakeLists.txt): the only fused multiply-adds are the
// explicit ones below, mirrored by gpu/kernels/ransac_score.cl, so counts match bit for bit.
#include <algorithm>
#include <cmath>

#include "gpu/scoring.hpp"

namespace ovo::gpu {
namespace {

#if defined(__FMA__)
inline float madd(float a, float b, float c) { return std::fma(a, b, c); }
#else
inline float madd(float a, float b, float c) { return a * b + c; }
#endif

// See inlierConstant() for the formula; the order of operations is part of the contract.
inline bool isInlier(const float e[9], float px, float py, float pz, float cx, float cy, float cz,
                     float k) {
  const float a0 = madd(e[2], pz, madd(e[1], py, e[0] * px));
  const float a1 = madd(e[5], pz, madd(e[4], py, e[3] * px));
  const float a2 = madd(e[8], pz, madd(e[7], py, e[6] * px));
  const float c0 = madd(e[6], cz, madd(e[3], cy, e[0] * cx));
  const float c1 = madd(e[7], cz, madd(e[4], cy, e[1] * cx));
  const float c2 = madd(e[8], cz, madd(e[5], cy, e[2] * cx));
  const float num = madd(cz, a2, madd(cy, a1, cx * a0));
  const float s = madd(c2, c2, madd(c1, c1, madd(c0, c0, madd(a2, a2, madd(a1, a1, a0 * a0)))));
  return num * num < k * s;
}

constexpr int kMatchChunk = 1024;  // 24 KB of bearings: stays in L1 across hypotheses

}  // namespace

bool cpuScoringUsesFma() {
#if defined(__FMA__)
  return true;
#else
  return false;
#endif
}

void scoreHypothesesCpu(const float* E, int h_begin, int h_end, const MatchesSoA& m, float k,
                        int* counts) {
  const int n = m.n;
  std::fill(counts, counts + (h_end - h_begin), 0);
  const float* __restrict px = m.prev;
  const float* __restrict py = m.prev + n;
  const float* __restrict pz = m.prev + 2 * n;
  const float* __restrict cx = m.cur;
  const float* __restrict cy = m.cur + n;
  const float* __restrict cz = m.cur + 2 * n;
  for (int i0 = 0; i0 < n; i0 += kMatchChunk) {
    const int i1 = std::min(n, i0 + kMatchChunk);
    for (int h = h_begin; h < h_end; ++h) {
      float e[9];
      for (int j = 0; j < 9; ++j) e[j] = E[9 * h + j];
      int count = 0;
      for (int i = i0; i < i1; ++i)
        count += isInlier(e, px[i], py[i], pz[i], cx[i], cy[i], cz[i], k) ? 1 : 0;
      counts[h - h_begin] += count;
    }
  }
}

void inlierFlagsCpu(const float* E9, const MatchesSoA& m, float k, std::uint8_t* flags) {
  const int n = m.n;
  float e[9];
  for (int j = 0; j < 9; ++j) e[j] = E9[j];
  for (int i = 0; i < n; ++i)
    flags[i] = isInlier(e, m.prev[i], m.prev[n + i], m.prev[2 * n + i], m.cur[i], m.cur[n + i],
                        m.cur[2 * n + i], k)
                   ? 1
                   : 0;
}

}  // namespace ovo::gpu
