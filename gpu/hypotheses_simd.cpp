// The batched minimal 8-point solver (gpu/hypotheses.hpp): every step is a loop over
// kEightPointLanes independent hypotheses with no data-dependent branch, so the compiler keeps
// the lanes in SIMD registers. Built with -march=native, -ffp-contract=off and -fno-math-errno
// (top CMakeLists.txt): only correctly rounded +, -, *, /, sqrt, so a lane's bits do not depend on
// how the lanes are grouped.
#include <algorithm>
#include <cmath>

#include "gpu/hypotheses.hpp"

namespace ovo::gpu {
namespace {

constexpr int L = kEightPointLanes;
constexpr int kJacobiSweeps = 5;  // 3x3 cyclic Jacobi converges quadratically: 5 sweeps suffice

// splitmix64 (Steele, Lea, Flood, "Fast splittable pseudorandom number generators", 2014).
inline std::uint64_t splitmix64(std::uint64_t& state) {
  std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

// One cyclic Jacobi rotation zeroing S(p, q) (Golub, Van Loan, "Matrix Computations", 8.5.2,
// sym.schur2): S <- J^T S J, V <- V J with J(p,p) = J(q,q) = c, J(p,q) = s, J(q,p) = -s.
inline void jacobiRotate(double S[3][3][L], double V[3][3][L], int p, int q) {
  for (int l = 0; l < L; ++l) {
    const double apq = S[p][q][l];
    const bool nonzero = apq != 0.0;
    const double tau = (S[q][q][l] - S[p][p][l]) / (nonzero ? 2.0 * apq : 1.0);
    const double t_raw = std::copysign(1.0, tau) / (std::fabs(tau) + std::sqrt(1.0 + tau * tau));
    const double t = nonzero ? t_raw : 0.0;
    const double c = 1.0 / std::sqrt(1.0 + t * t);
    const double s = t * c;
    for (int r = 0; r < 3; ++r) {  // columns p, q of S and V
      const double sp = S[r][p][l], sq = S[r][q][l];
      S[r][p][l] = c * sp - s * sq;
      S[r][q][l] = s * sp + c * sq;
      const double vp = V[r][p][l], vq = V[r][q][l];
      V[r][p][l] = c * vp - s * vq;
      V[r][q][l] = s * vp + c * vq;
    }
    for (int r = 0; r < 3; ++r) {  // rows p, q of S
      const double sp = S[p][r][l], sq = S[q][r][l];
      S[p][r][l] = c * sp - s * sq;
      S[q][r][l] = s * sp + c * sq;
    }
  }
}

}  // namespace

std::array<int, 8> sampleIndices(std::uint64_t seed, std::uint64_t k, int num_matches) {
  std::uint64_t key = seed;
  std::uint64_t state = splitmix64(key) ^ ((k + 1) * 0xD1B54A32D192ED03ull);
  std::array<int, 8> idx{};
  const auto n = static_cast<unsigned __int128>(num_matches);
  for (int j = 0; j < 8; ++j) {
    for (;;) {
      const int c = static_cast<int>((static_cast<unsigned __int128>(splitmix64(state)) * n) >> 64);
      if (std::find(idx.begin(), idx.begin() + j, c) == idx.begin() + j) {
        idx[j] = c;
        break;
      }
    }
  }
  return idx;
}

void eightPointLanes(const double prev[8][3][L], const double cur[8][3][L], double E_out[9][L],
                     bool valid[L]) {
  // A_i = kron(b_cur_i, b_prev_i), so that A_i vec_rowmajor(E) = b_cur_i^T E b_prev_i.
  double A[8][9][L];
  for (int i = 0; i < 8; ++i)
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c)
        for (int l = 0; l < L; ++l) A[i][3 * r + c][l] = cur[i][r][l] * prev[i][c][l];

  // Householder QR of A^T (9x8): reflector k acts on entries k..8 and is stored in row k.
  double beta[8][L];
  for (int k = 0; k < 8; ++k) {
    double norm2[L];
    for (int l = 0; l < L; ++l) norm2[l] = 0.0;
    for (int j = k; j < 9; ++j)
      for (int l = 0; l < L; ++l) norm2[l] += A[k][j][l] * A[k][j][l];
    for (int l = 0; l < L; ++l) {
      const double norm = std::sqrt(norm2[l]);
      const double x0 = A[k][k][l];
      const double vnorm2 = 2.0 * norm * (norm + std::fabs(x0));  // |x - alpha e_k|^2
      A[k][k][l] = x0 + std::copysign(norm, x0);                  // alpha = -sign(x0) |x|
      beta[k][l] = vnorm2 > 0.0 ? 2.0 / vnorm2 : 0.0;
    }
    for (int i = k + 1; i < 8; ++i) {
      double d[L];
      for (int l = 0; l < L; ++l) d[l] = 0.0;
      for (int j = k; j < 9; ++j)
        for (int l = 0; l < L; ++l) d[l] += A[k][j][l] * A[i][j][l];
      for (int l = 0; l < L; ++l) d[l] *= beta[k][l];
      for (int j = k; j < 9; ++j)
        for (int l = 0; l < L; ++l) A[i][j][l] -= d[l] * A[k][j][l];
    }
  }
  // The null vector z = H_0 H_1 ... H_7 e_8: orthogonal to every row of A.
  double z[9][L];
  for (int j = 0; j < 9; ++j)
    for (int l = 0; l < L; ++l) z[j][l] = j == 8 ? 1.0 : 0.0;
  for (int k = 7; k >= 0; --k) {
    double d[L];
    for (int l = 0; l < L; ++l) d[l] = 0.0;
    for (int j = k; j < 9; ++j)
      for (int l = 0; l < L; ++l) d[l] += A[k][j][l] * z[j][l];
    for (int l = 0; l < L; ++l) d[l] *= beta[k][l];
    for (int j = k; j < 9; ++j)
      for (int l = 0; l < L; ++l) z[j][l] -= d[l] * A[k][j][l];
  }

  // Projection: eigenvectors of S = E^T E by cyclic Jacobi, E = z reshaped row-major.
  double S[3][3][L], V[3][3][L];
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      for (int l = 0; l < L; ++l) {
        S[a][b][l] = z[a][l] * z[b][l] + z[3 + a][l] * z[3 + b][l] + z[6 + a][l] * z[6 + b][l];
        V[a][b][l] = a == b ? 1.0 : 0.0;
      }
  for (int sweep = 0; sweep < kJacobiSweeps; ++sweep) {
    jacobiRotate(S, V, 0, 1);
    jacobiRotate(S, V, 0, 2);
    jacobiRotate(S, V, 1, 2);
  }
  for (int l = 0; l < L; ++l) {
    const double d0 = S[0][0][l], d1 = S[1][1][l], d2 = S[2][2][l];
    const int smallest = (d0 <= d1 && d0 <= d2) ? 0 : (d1 <= d2 ? 1 : 2);
    const int i1 = smallest == 0 ? 1 : 0;
    const int i2 = smallest == 2 ? 1 : 2;
    double v1[3], v2[3], u1[3], u2[3];
    for (int r = 0; r < 3; ++r) {
      v1[r] = V[r][i1][l];
      v2[r] = V[r][i2][l];
    }
    for (int r = 0; r < 3; ++r) {
      u1[r] = z[3 * r][l] * v1[0] + z[3 * r + 1][l] * v1[1] + z[3 * r + 2][l] * v1[2];
      u2[r] = z[3 * r][l] * v2[0] + z[3 * r + 1][l] * v2[1] + z[3 * r + 2][l] * v2[2];
    }
    const double n1 = std::sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
    const double n2 = std::sqrt(u2[0] * u2[0] + u2[1] * u2[1] + u2[2] * u2[2]);
    const double n_max = std::max(n1, n2), n_min = std::min(n1, n2);
    bool ok = n_max > 0.0 && n_min > 1e-9 * n_max && n_max < 1e300;
    const double inv1 = ok ? 1.0 / n1 : 0.0, inv2 = ok ? 1.0 / n2 : 0.0;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) {
        const double e = u1[r] * inv1 * v1[c] + u2[r] * inv2 * v2[c];
        ok = ok && std::isfinite(e);
        E_out[3 * r + c][l] = e;
      }
    valid[l] = ok;
    if (!ok)
      for (int j = 0; j < 9; ++j) E_out[j][l] = 0.0;
  }
}

void generateHypothesesCpu(const BearingsSoA& m, std::uint64_t seed, int h_begin, int h_end,
                           float* E_rowmajor) {
  const int n = m.n;
  double prev[8][3][L], cur[8][3][L], E[9][L];
  bool valid[L];
  for (int h0 = h_begin; h0 < h_end; h0 += L) {
    for (int l = 0; l < L; ++l) {
      // Lanes past h_end solve hypotheses that are not stored: the batch always has L lanes.
      const auto idx = sampleIndices(seed, static_cast<std::uint64_t>(h0 + l), n);
      for (int j = 0; j < 8; ++j)
        for (int r = 0; r < 3; ++r) {
          prev[j][r][l] = m.prev[r * n + idx[j]];
          cur[j][r][l] = m.cur[r * n + idx[j]];
        }
    }
    eightPointLanes(prev, cur, E, valid);
    const int lanes = std::min(L, h_end - h0);
    for (int l = 0; l < lanes; ++l)
      for (int j = 0; j < 9; ++j)
        E_rowmajor[9 * static_cast<std::size_t>(h0 - h_begin + l) + j] =
            static_cast<float>(E[j][l]);
  }
}

}  // namespace ovo::gpu
